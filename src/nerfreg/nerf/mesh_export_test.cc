#include "nerfreg/nerf/mesh_export.h"

#include <gtest/gtest.h>

#include <map>

#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A ball of radius r sampled as r - |x| (positive inside) on a 32^3-cell grid over [-1, 1]^3.
ColoredMesh BallMesh(float r) {
  const int G = 32;
  const auto a = torch::linspace(-1, 1, G + 1);
  const auto g = torch::meshgrid({a, a, a}, "ij");
  const auto values = r - torch::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  return MarchingCubes(values, 0.0, {-1, -1, -1}, {1, 1, 1});
}

TEST(MeshExport, MarchingCubesBallIsClosedOutwardAndOnTheSphere) {
  const float r = 0.6f;
  const ColoredMesh m = BallMesh(r);
  ASSERT_GT(m.triangles.size(0), 500);
  // Vertices lie on the sphere (linear interpolation of a distance: error well under a cell).
  EXPECT_LT((m.vertices.norm(2, 1) - r).abs().max().item<float>(), 0.01f);
  // Closed 2-manifold: every edge is shared by exactly two triangles, once in each direction.
  std::map<std::pair<std::int64_t, std::int64_t>, int> directed;
  const auto t = m.triangles.contiguous();
  const std::int64_t* p = t.data_ptr<std::int64_t>();
  for (std::int64_t i = 0; i < t.size(0); ++i)
    for (int j = 0; j < 3; ++j) ++directed[{p[3 * i + j], p[3 * i + (j + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1);
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u);
  }
  // Counter-clockwise seen from outside: face normals point away from the centre, and the
  // enclosed volume (divergence theorem) is the ball's.
  const auto a = m.vertices.index_select(0, m.triangles.select(1, 0)),
             b = m.vertices.index_select(0, m.triangles.select(1, 1)),
             c = m.vertices.index_select(0, m.triangles.select(1, 2));
  const auto face = torch::cross(b - a, c - a, 1);
  EXPECT_GT(((face * (a + b + c)).sum(1) > 0).to(torch::kFloat32).mean().item<float>(), 0.99f);
  const double volume = (a * torch::cross(b, c, 1)).sum().item<double>() / 6.0;
  EXPECT_NEAR(volume, 4.0 / 3.0 * M_PI * r * r * r, 0.02 * volume);
  // Vertex normals are outward and unit.
  const auto n = VertexNormals(m.vertices, m.triangles);
  EXPECT_GT((n * m.vertices / r).sum(1).min().item<float>(), 0.95f);
}

TEST(MeshExport, EmptyGridGivesEmptyMeshAndPlyIsWritten) {
  const ColoredMesh empty = MarchingCubes(torch::zeros({5, 5, 5}), 1.0, {0, 0, 0}, {1, 1, 1});
  EXPECT_EQ(empty.vertices.size(0), 0);
  EXPECT_EQ(empty.triangles.size(0), 0);
  ColoredMesh m = BallMesh(0.5f);
  m.normals = VertexNormals(m.vertices, m.triangles);
  m.colors = torch::rand({m.vertices.size(0), 3});
  ScopedTempDir dir;
  WriteMeshPly(m, dir.File("ball.ply"));
  const std::string bytes = ReadFileToString(dir.File("ball.ply"));
  const std::size_t end = bytes.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(bytes.find("element vertex " + std::to_string(m.vertices.size(0))), std::string::npos);
  EXPECT_EQ(bytes.size() - end - 11, std::size_t(m.vertices.size(0) * 27 + m.triangles.size(0) * 13));
}

}  // namespace
}  // namespace nerfreg
