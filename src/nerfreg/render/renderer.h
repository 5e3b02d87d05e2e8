#pragma once
// Ray-cast rendering of a mesh: RGBA image + z-depth map per view. The shading is chosen to make
// texture and shape visible to a NeRF and to feature matching, not to be physically based:
// albedo (per-triangle materials: their texture, or their flat colour modulated by a procedural
// pattern; else the mesh's texture, vertex colours modulated by the pattern, or a procedural albedo
// when the mesh has none of these) x (ambient + two directional lights + a headlight), two-sided.
#include <Eigen/Core>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/render/mesh.h"
#include "nerfreg/render/raycaster.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

struct RenderOptions {
  int supersample = 2;              // rays per pixel side (anti-aliasing of colour and alpha)
  float ambient = 0.35f;            // light that reaches every surface
  float texture_modulation = 0.3f;  // strength of the procedural pattern over vertex colours
  float pattern_scale = 4.0f;       // spatial frequency of the procedural pattern (per unit)
  void Check() const;               // throws std::invalid_argument
};

struct RenderResult {
  Image rgba;   // [H, W, 4]; alpha 0 where no surface (fractional at silhouettes)
  Image depth;  // [H, W, 1]; z-depth (along the optical axis) of the pixel centre's hit, 0 if none
};

RenderResult RenderView(const RayCaster& caster, const TriangleMesh& mesh, const Camera& camera,
                        const Rigid3d& cam_from_world, const RenderOptions& options);

// The procedural albedo in [0, 1]^3 at an object-space point: smooth value noise at two scales
// mapped through a colour palette, so untextured meshes still have features.
Eigen::Vector3f ProceduralAlbedo(const Eigen::Vector3f& p, float scale);
// Scalar pattern in [0, 1] used to modulate vertex colours.
float ProceduralPattern(const Eigen::Vector3f& p, float scale);

}  // namespace nerfreg
