#pragma once
// Triangle meshes as the renderer needs them. Loading goes through Open3D's readers (OFF, PLY,
// OBJ with materials, STL, glTF/GLB) behind this header, so Open3D stays out of every other layer.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "nerfreg/util/image.h"

namespace nerfreg {

// One material of a mesh read with several (an OBJ's "usemtl" groups, e.g. Sweet Home 3D furniture).
struct MeshMaterial {
  std::string name;
  Eigen::Vector3f diffuse = Eigen::Vector3f::Constant(0.8f);  // RGB in [0, 1] (MTL Kd), where no texture
  Image texture;  // empty, or the RGB albedo texture (MTL map_Kd), sampled at triangle_uvs
};

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<Eigen::Vector3f> vertex_colors;  // empty, or one RGB in [0, 1] per vertex
  std::vector<Eigen::Vector2f> triangle_uvs;   // empty, or 3 per triangle (texture coordinates)
  Image texture;                               // empty, or the albedo texture for triangle_uvs
  // Per-triangle materials; when present they colour the mesh (texture and vertex_colors unused).
  std::vector<MeshMaterial> materials;  // empty, or the materials triangle_materials index
  std::vector<int> triangle_materials;  // empty, or one index into materials per triangle

  bool HasColors() const { return !vertex_colors.empty() && vertex_colors.size() == vertices.size(); }
  bool HasMaterials() const { return !materials.empty() && triangle_materials.size() == triangles.size(); }
  bool HasTexture() const { return !texture.empty() && triangle_uvs.size() == 3 * triangles.size(); }
  // Axis-aligned bounds (min, max); zeros for an empty mesh.
  void Bounds(Eigen::Vector3f* min, Eigen::Vector3f* max) const;
  // Appends another mesh (colours, materials and uvs kept only when both have them; the single
  // `texture` is dropped).
  void Append(const TriangleMesh& other);
  // Throws InputError(source: ...) when empty or indices (vertex, material) are out of range.
  void Check(const std::string& source) const;
};

// Loads OFF, PLY, OBJ, STL, glTF or GLB. Throws InputError naming the file when it is missing,
// unreadable or has no triangles, and, before Open3D reads them, when an OFF, PLY or STL file
// claims more elements than it holds or has a face of fewer than 3 vertices or with an index out of
// range (Open3D would allocate or read out of bounds). OBJ / glTF / GLB are not pre-checked.
TriangleMesh LoadMesh(const std::string& path);

// Centres the bounding box at the origin and scales the largest side to `largest_side`
// (DReg-NeRF's convention: 2.5). Returns the scale applied.
float NormalizeMesh(TriangleMesh* mesh, float largest_side = 2.5f);

}  // namespace nerfreg
