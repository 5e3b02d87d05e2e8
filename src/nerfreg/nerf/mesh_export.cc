#include "nerfreg/nerf/mesh_export.h"

#include <open3d/pipelines/integration/MarchingCubesConst.h>  // edge_table, tri_table, shift, edge_shift

#include <cstring>
#include <string>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

void MeshExportOptions::Check() const {
  if (resolution < 2 || resolution > 1024) ThrowInputError("--resolution", "", "2..1024");
  if (!(density_threshold > 0)) ThrowInputError("--density", "", "a positive density threshold");
}

ColoredMesh MarchingCubes(const torch::Tensor& values_in, double iso, const std::vector<double>& box_min,
                          const std::vector<double>& box_max) {
  TORCH_CHECK(values_in.dim() == 3 && values_in.size(0) == values_in.size(1) &&
                  values_in.size(0) == values_in.size(2) && values_in.size(0) >= 2,
              "MarchingCubes: values must be [G+1, G+1, G+1]");
  TORCH_CHECK(box_min.size() == 3 && box_max.size() == 3, "MarchingCubes: 3D box expected");
  const auto values = values_in.to(torch::kFloat32).contiguous();
  const float* v = values.data_ptr<float>();
  const std::int64_t n = values.size(0), G = n - 1;
  auto at = [&](std::int64_t x, std::int64_t y, std::int64_t z) { return v[(x * n + y) * n + z]; };
  float cell[3];
  for (int d = 0; d < 3; ++d) cell[d] = static_cast<float>((box_max[d] - box_min[d]) / G);
  const float fiso = static_cast<float>(iso);

  // One vertex per crossed grid edge, shared by the (up to 4) cells around it. Edge key: start
  // vertex (x, y, z) and direction.
  std::vector<std::int32_t> edge_vertex(static_cast<std::size_t>(n * n * n * 3), -1);
  std::vector<float> verts;
  std::vector<std::int64_t> tris;
  auto edge_vertex_id = [&](std::int64_t x, std::int64_t y, std::int64_t z, int dir) {
    std::int32_t& id = edge_vertex[((x * n + y) * n + z) * 3 + dir];
    if (id >= 0) return id;
    const std::int64_t x1 = x + (dir == 0), y1 = y + (dir == 1), z1 = z + (dir == 2);
    const float v0 = at(x, y, z), v1 = at(x1, y1, z1);
    const float t = v1 != v0 ? std::min(std::max((fiso - v0) / (v1 - v0), 0.f), 1.f) : 0.5f;
    const float p[3] = {float(x) + (dir == 0) * t, float(y) + (dir == 1) * t, float(z) + (dir == 2) * t};
    for (int d = 0; d < 3; ++d) verts.push_back(static_cast<float>(box_min[d]) + p[d] * cell[d]);
    id = static_cast<std::int32_t>(verts.size() / 3 - 1);
    return id;
  };
  for (std::int64_t x = 0; x < G; ++x) {
    for (std::int64_t y = 0; y < G; ++y) {
      for (std::int64_t z = 0; z < G; ++z) {
        int cube = 0;
        for (int k = 0; k < 8; ++k)
          if (at(x + shift[k](0), y + shift[k](1), z + shift[k](2)) > fiso) cube |= 1 << k;
        if (edge_table[cube] == 0) continue;
        for (int k = 0; tri_table[cube][k] != -1; k += 3) {
          std::int64_t ids[3];
          for (int j = 0; j < 3; ++j) {
            const auto& e = edge_shift[tri_table[cube][k + j]];
            ids[j] = edge_vertex_id(x + e(0), y + e(1), z + e(2), e(3));
          }
          // The tables wind triangles clockwise seen from the side with the set bits (inside):
          // emit them reversed so they are counter-clockwise seen from outside.
          tris.insert(tris.end(), {ids[0], ids[2], ids[1]});
        }
      }
    }
  }
  ColoredMesh m;
  m.vertices =
      torch::from_blob(verts.data(), {static_cast<std::int64_t>(verts.size() / 3), 3}, torch::kFloat32).clone();
  m.triangles = torch::from_blob(tris.data(), {static_cast<std::int64_t>(tris.size() / 3), 3}, torch::kInt64).clone();
  return m;
}

torch::Tensor VertexNormals(const torch::Tensor& vertices, const torch::Tensor& triangles) {
  auto normals = torch::zeros_like(vertices);
  if (triangles.size(0) == 0) return normals;
  const auto a = vertices.index_select(0, triangles.select(1, 0)), b = vertices.index_select(0, triangles.select(1, 1)),
             c = vertices.index_select(0, triangles.select(1, 2));
  const auto face = torch::cross(b - a, c - a, 1);  // length = 2 x area: area-weighted
  for (int j = 0; j < 3; ++j) normals.index_add_(0, triangles.select(1, j), face);
  return normals / normals.norm(2, 1, true).clamp_min(1e-12);
}

ColoredMesh ExtractMesh(NerfBlock& block, const MeshExportOptions& options) {
  options.Check();
  torch::NoGradGuard no_grad;
  const int G = options.resolution;
  const auto& mn = block.field_options.aabb_min;
  const auto& mx = block.field_options.aabb_max;
  std::vector<torch::Tensor> axes;
  for (int d = 0; d < 3; ++d) axes.push_back(torch::linspace(mn[d], mx[d], G + 1, torch::kFloat32));
  const auto grid = torch::meshgrid({axes[0], axes[1], axes[2]}, "ij");
  const auto points = torch::stack({grid[0], grid[1], grid[2]}, -1).reshape({-1, 3}).contiguous();
  constexpr std::int64_t kChunk = 1 << 16;
  std::vector<torch::Tensor> sigma;
  for (std::int64_t s = 0; s < points.size(0); s += kChunk)
    sigma.push_back(block.field->Density(points.slice(0, s, s + kChunk)));
  // Marched in the field's frame, where its box is; a moved block's threshold is per unit length
  // of its own frame (BlockDensity).
  ColoredMesh m = MarchingCubes(torch::cat(sigma).view({G + 1, G + 1, G + 1}),
                                options.density_threshold * block.world_from_field.scale, mn, mx);
  m.normals = VertexNormals(m.vertices, m.triangles);
  std::vector<torch::Tensor> rgb;
  for (std::int64_t s = 0; s < m.vertices.size(0); s += kChunk) {
    // Seen from outside along the normal, as a camera looking at the surface would.
    rgb.push_back(block.field->Forward(m.vertices.slice(0, s, s + kChunk), -m.normals.slice(0, s, s + kChunk)).second);
  }
  m.colors = rgb.empty() ? torch::zeros({0, 3}) : torch::cat(rgb);
  if (block.Moved()) {
    m.vertices = FromFieldFrame(block, m.vertices);
    m.normals = VertexNormals(m.vertices, m.triangles);
  }
  return m;
}

void WriteMeshPly(const ColoredMesh& mesh, const std::string& path) {
  const std::int64_t V = mesh.vertices.size(0), T = mesh.triangles.size(0);
  const auto pos = mesh.vertices.to(torch::kFloat32).contiguous();
  const auto nrm = (mesh.normals.defined() ? mesh.normals : torch::zeros({V, 3})).to(torch::kFloat32).contiguous();
  const auto col = ((mesh.colors.defined() ? mesh.colors : torch::ones({V, 3})).clamp(0, 1) * 255 + 0.5)
                       .to(torch::kUInt8)
                       .contiguous();
  const auto tri = mesh.triangles.to(torch::kInt32).contiguous();
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment nerfreg nerf export --mesh\nelement vertex " +
                    std::to_string(V) +
                    "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
                    "property float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face " +
                    std::to_string(T) + "\nproperty list uchar int vertex_indices\nend_header\n";
  const std::size_t header = out.size();
  out.resize(header + V * (6 * sizeof(float) + 3) + T * (1 + 3 * sizeof(std::int32_t)));
  char* p = out.data() + header;
  const float* pp = pos.data_ptr<float>();
  const float* pn = nrm.data_ptr<float>();
  const std::uint8_t* pc = col.data_ptr<std::uint8_t>();
  const std::int32_t* pt = tri.data_ptr<std::int32_t>();
  for (std::int64_t i = 0; i < V; ++i) {  // x86-64 is little-endian: raw copies
    std::memcpy(p, pp + 3 * i, 12);
    std::memcpy(p + 12, pn + 3 * i, 12);
    std::memcpy(p + 24, pc + 3 * i, 3);
    p += 27;
  }
  for (std::int64_t i = 0; i < T; ++i) {
    *p++ = 3;
    std::memcpy(p, pt + 3 * i, 12);
    p += 12;
  }
  WriteFileAtomic(path, out);
}

}  // namespace nerfreg
