#include "nerfreg/reg/reg_grid.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>

#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A D=16 grid over [-1, 1]^3 with a small solid ball of masked voxels off-centre.
RegGrid BallGrid() {
  const int d = 16;
  RegGrid g;
  g.aabb_min = Eigen::Vector3d::Constant(-1);
  g.aabb_max = Eigen::Vector3d::Constant(1);
  const auto idx = torch::arange(d, torch::kFloat32);
  const auto ijk = torch::meshgrid({idx, idx, idx}, "ij");
  g.xyz = -1 + (torch::stack({ijk[0], ijk[1], ijk[2]}, -1) + 0.5) * (2.0f / d);
  const auto r = (g.xyz - torch::tensor({0.2f, -0.1f, 0.0f})).norm(2, 3);
  g.mask = r < 0.4;
  g.surface = g.mask.to(torch::kFloat32) * 0.9;
  g.rgba = torch::zeros({4, d, d, d});
  g.rgba.select(0, 0).masked_fill_(g.mask, 0.7);
  g.rgba.select(0, 3).masked_fill_(g.mask, 0.5);
  return g;
}

TEST(RegGrid, SaveLoadRoundTrip) {
  ScopedTempDir dir;
  const RegGrid g = BallGrid();
  SaveRegGrid(g, dir.File("g.pt"));
  const RegGrid h = LoadRegGrid(dir.File("g.pt"));
  EXPECT_TRUE(torch::equal(g.rgba, h.rgba));
  EXPECT_TRUE(torch::equal(g.xyz, h.xyz));
  EXPECT_TRUE(torch::equal(g.surface, h.surface));
  EXPECT_TRUE(torch::equal(g.mask, h.mask));
  EXPECT_EQ(g.aabb_min, h.aabb_min);
  EXPECT_EQ(h.MaskedXyz().size(0), g.mask.sum().item<std::int64_t>());
}

TEST(RegGrid, BadFilesAreInputErrorsNamingTheFile) {
  ScopedTempDir dir;
  EXPECT_NE(InputErrorOf([&] { LoadRegGrid(dir.File("missing.pt")); }).find("missing.pt"), std::string::npos);
  SaveRegGrid(BallGrid(), dir.File("g.pt"));
  std::string bytes;
  {
    std::ifstream in(dir.File("g.pt"), std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(dir.File("cut.pt"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_NE(InputErrorOf([&] { LoadRegGrid(dir.File("cut.pt")); }).find("cut.pt"), std::string::npos);
}

TEST(RegGrid, TransformResamplesTheSameSurfaceInTheNewFrame) {
  const RegGrid g = BallGrid();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.3, -0.2, 0.1);
  const RegGrid h = TransformRegGrid(g, R, t);
  // About as many masked voxels, and every new sample point maps back into the ball (radius 0.4
  // plus a cell diagonal for the resampling).
  EXPECT_NEAR(double(h.mask.sum().item<std::int64_t>()), double(g.mask.sum().item<std::int64_t>()), 0.1 * g.mask.sum().item<std::int64_t>());
  const auto b = h.MaskedXyz().to(torch::kFloat64);
  Eigen::Matrix3d Rt = R.transpose();
  const auto Rinv = torch::from_blob(Rt.data(), {3, 3}, torch::kFloat64).t().clone();  // row-major R^T
  const auto back = (b - torch::tensor({t.x(), t.y(), t.z()}, torch::kFloat64)).matmul(Rinv.t());
  const double r = (back - torch::tensor({0.2, -0.1, 0.0}, torch::kFloat64)).norm(2, 1).max().item<double>();
  EXPECT_LT(r, 0.4 + std::sqrt(3.0) * 2.0 / 16);
  EXPECT_GT(r, 0.3);
  EXPECT_NEAR((h.aabb_max - h.aabb_min).x(), 2.0, 1e-9);
}

}  // namespace
}  // namespace nerfreg
