#pragma once
// Procedural content, seeded and reproducible: the training data of the learned models (no
// dataset can be downloaded here). Objects are random unions of primitives with varied colours;
// forward-facing scenes put several objects at different depths in front of a textured backdrop.
#include <Eigen/Core>

#include <string>

#include "nerfreg/render/mesh.h"

namespace nerfreg {

// Primitives centred at the origin, with one vertex colour (later modulated by the renderer).
TriangleMesh MakeBox(const Eigen::Vector3f& half_extents, const Eigen::Vector3f& color, int subdivisions = 4);
TriangleMesh MakeSphere(float radius, const Eigen::Vector3f& color, int rings = 16, int segments = 32);
TriangleMesh MakeCylinder(float radius, float height, const Eigen::Vector3f& color, int segments = 32);
TriangleMesh MakeTorus(float major_radius, float minor_radius, const Eigen::Vector3f& color, int rings = 32,
                       int segments = 16);
// A subdivided rectangle in the x-z plane at y = 0, normal -y, with the procedural albedo baked
// into its vertex colours (the backdrop of forward-facing scenes).
TriangleMesh MakeBackdrop(float width, float height, int cells_x, int cells_z, float pattern_scale);

// Applies x -> s * R * x + t to every vertex.
void TransformMesh(TriangleMesh* mesh, const Eigen::Matrix3f& rotation, const Eigen::Vector3f& translation,
                   float scale = 1.f);

// 3 to 8 primitives, normalised so the largest bbox side is 2.5 (the DReg-NeRF convention).
TriangleMesh ProceduralObject(unsigned seed);

// A mesh (normalised, centred at the origin) in front of a textured backdrop at y = backdrop_y:
// a forward-facing scene of a given object. Texture and vertex colours of the mesh are dropped if
// it has only one of them (one mesh holds one kind of albedo).
TriangleMesh WithBackdrop(const TriangleMesh& mesh, float backdrop_y = 2.0f);

// The surfaces of a forward-facing scene: hard cases for feature matching (`render --material`).
//  textured:    the noise-palette backdrop (the training scenes).
//  low-texture: a uniform pale backdrop; objects keep their flat colours. Render it with
//               MaterialTextureModulation's faint pattern: SIFT then finds little beyond silhouettes.
//  repetitive:  a regular two-colour tile grid as backdrop (every tile alike), no noise pattern:
//               descriptors match many tiles equally well.
enum class SceneMaterial { kTextured, kLowTexture, kRepetitive };
SceneMaterial ParseSceneMaterial(const std::string& name);  // throws InputError naming --material
// The renderer's pattern strength over vertex colours for the material (RenderOptions::texture_modulation).
float MaterialTextureModulation(SceneMaterial material);

// A backdrop at y = backdrop_y and 3 to 6 objects between y = -1.5 and y = 1.2. The objects and
// their placement depend on the seed only, not on the material.
TriangleMesh ProceduralForwardScene(unsigned seed, float backdrop_y = 2.0f,
                                    SceneMaterial material = SceneMaterial::kTextured);

// A scene with layered depth in front of cameras whose optical axes are near +y from the plane
// y = camera_y (HandheldTrajectory's): objects at several depths, log-uniform between near_depth
// and half the backdrop's depth (one of them in the nearest layer), each sized and placed in
// proportion to its depth so that it covers a similar part of the image and stays in view, and a
// backdrop at backdrop_depth large enough to fill every view. Depths are measured from the camera
// plane, scene units; backdrop_depth / near_depth is the near / far ratio of LLFF's captures (about
// 10 or more). The backdrop's pattern is scaled with its depth so it shows as fine in the image as
// the forward scenes' does.
struct LayeredSceneOptions {
  float camera_y = -4.f;           // the cameras' plane (HandheldOptions::distance)
  float near_depth = 1.5f;         // the nearest layer's depth from the camera plane
  float backdrop_depth = 16.f;     // the backdrop's depth from the camera plane
  float tan_half_fov_x = 0.4545f;  // the views' half field of view (HandheldOptions: 0.5 / 1.1)
  float aspect = 0.75f;            // height / width of the views
  void Check() const;              // throws std::invalid_argument
};
TriangleMesh ProceduralLayeredScene(unsigned seed, SceneMaterial material = SceneMaterial::kTextured,
                                    const LayeredSceneOptions& options = {});

// A room for RoomWalkTrajectory: floor (z = 0), ceiling, four walls, each with its own procedural
// albedo, furniture (primitives up to a metre or so) along the walls and a group in the middle,
// clear of the walk's ellipse. Scene units are metres-like: 6 x 5 x 2.6. Materials: textured or
// low-texture (repetitive throws InputError naming --material).
struct RoomOptions {
  float width = 6.f, depth = 5.f, height = 2.6f;  // x, y, z extents
  // The walk's ellipse (RoomWalkOptions::radius_x, radius_y), which the furniture keeps clear of.
  float walk_radius_x = 1.6f, walk_radius_y = 1.2f;
  void Check() const;  // throws std::invalid_argument
};
TriangleMesh ProceduralRoom(unsigned seed, SceneMaterial material = SceneMaterial::kTextured,
                            const RoomOptions& options = {});

}  // namespace nerfreg
