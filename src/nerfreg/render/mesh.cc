#include "nerfreg/render/mesh.h"

#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>
#include <open3d/utility/Logging.h>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

void TriangleMesh::Bounds(Eigen::Vector3f* mn, Eigen::Vector3f* mx) const {
  if (vertices.empty()) {
    *mn = *mx = Eigen::Vector3f::Zero();
    return;
  }
  *mn = *mx = vertices[0];
  for (const auto& v : vertices) {
    *mn = mn->cwiseMin(v);
    *mx = mx->cwiseMax(v);
  }
}

void TriangleMesh::Append(const TriangleMesh& o) {
  const bool colors = (vertices.empty() || HasColors()) && o.HasColors();
  const int offset = static_cast<int>(vertices.size());
  vertices.insert(vertices.end(), o.vertices.begin(), o.vertices.end());
  for (const auto& t : o.triangles) triangles.push_back(t + Eigen::Vector3i::Constant(offset));
  if (colors) vertex_colors.insert(vertex_colors.end(), o.vertex_colors.begin(), o.vertex_colors.end());
  else vertex_colors.clear();
  triangle_uvs.clear();  // one texture per mesh: a union drops textures
  texture = Image();
}

void TriangleMesh::Check(const std::string& source) const {
  if (vertices.empty() || triangles.empty()) ThrowInputError(source, "triangles", "a mesh with at least one triangle");
  const int n = static_cast<int>(vertices.size());
  for (const auto& t : triangles) {
    if ((t.array() < 0).any() || (t.array() >= n).any()) ThrowInputError(source, "triangles", "vertex indices in range");
  }
  for (const auto& v : vertices) {
    if (!v.allFinite()) ThrowInputError(source, "vertices", "finite coordinates");
  }
}

TriangleMesh LoadMesh(const std::string& path) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing mesh file");
  const std::string ext = LowerExtension(path);
  if (ext != ".off" && ext != ".ply" && ext != ".obj" && ext != ".stl" && ext != ".gltf" && ext != ".glb") {
    ThrowInputError(path, "extension", ".off, .ply, .obj, .stl, .gltf or .glb");
  }
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  open3d::geometry::TriangleMesh o3d;
  open3d::io::ReadTriangleMeshOptions options;
  if (!open3d::io::ReadTriangleMesh(path, o3d, options) || o3d.triangles_.empty()) {
    ThrowInputError(path, "", "a readable triangle mesh with at least one triangle");
  }
  TriangleMesh mesh;
  for (const auto& v : o3d.vertices_) mesh.vertices.push_back(v.cast<float>());
  for (const auto& t : o3d.triangles_) mesh.triangles.push_back(t);
  if (o3d.HasVertexColors()) {
    for (const auto& c : o3d.vertex_colors_) mesh.vertex_colors.push_back(c.cast<float>().cwiseMax(0.f).cwiseMin(1.f));
  }
  if (o3d.HasTriangleUvs() && !o3d.textures_.empty() && !o3d.textures_[0].IsEmpty()) {
    const auto& tex = o3d.textures_[0];
    if (tex.bytes_per_channel_ == 1 && (tex.num_of_channels_ == 3 || tex.num_of_channels_ == 4 || tex.num_of_channels_ == 1)) {
      mesh.texture = Image(tex.width_, tex.height_, 3);
      for (int y = 0; y < tex.height_; ++y)
        for (int x = 0; x < tex.width_; ++x)
          for (int c = 0; c < 3; ++c) {
            const int src_c = tex.num_of_channels_ == 1 ? 0 : c;
            mesh.texture.at(x, y, c) = *tex.PointerAt<uint8_t>(x, y, src_c) / 255.f;
          }
      for (const auto& uv : o3d.triangle_uvs_) mesh.triangle_uvs.push_back(uv.cast<float>());
    }
  }
  mesh.Check(path);
  return mesh;
}

float NormalizeMesh(TriangleMesh* mesh, float largest_side) {
  Eigen::Vector3f mn, mx;
  mesh->Bounds(&mn, &mx);
  const Eigen::Vector3f centre = 0.5f * (mn + mx);
  const float side = (mx - mn).maxCoeff();
  const float s = side > 0 ? largest_side / side : 1.f;
  for (auto& v : mesh->vertices) v = (v - centre) * s;
  return s;
}

}  // namespace nerfreg
