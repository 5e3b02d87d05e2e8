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
  EXPECT_NEAR(double(h.mask.sum().item<std::int64_t>()), double(g.mask.sum().item<std::int64_t>()),
              0.1 * g.mask.sum().item<std::int64_t>());
  const auto b = h.MaskedXyz().to(torch::kFloat64);
  Eigen::Matrix3d Rt = R.transpose();
  const auto Rinv = torch::from_blob(Rt.data(), {3, 3}, torch::kFloat64).t().clone();  // row-major R^T
  const auto back = (b - torch::tensor({t.x(), t.y(), t.z()}, torch::kFloat64)).matmul(Rinv.t());
  const double r = (back - torch::tensor({0.2, -0.1, 0.0}, torch::kFloat64)).norm(2, 1).max().item<double>();
  EXPECT_LT(r, 0.4 + std::sqrt(3.0) * 2.0 / 16);
  EXPECT_GT(r, 0.3);
  EXPECT_NEAR((h.aabb_max - h.aabb_min).x(), 2.0, 1e-9);
}

Eigen::Vector3d MaskedCentroid(const RegGrid& g) {
  const auto c = g.MaskedXyz().to(torch::kFloat64).mean(0);
  return {c[0].item<double>(), c[1].item<double>(), c[2].item<double>()};
}

TEST(RegGrid, MirrorFlipsAboutTheBoxCentreExactly) {
  RegGrid g = BallGrid();
  // A box off the origin, so the mirror plane (x = 0.5) is not the origin's.
  g.aabb_min.x() += 0.5;
  g.aabb_max.x() += 0.5;
  g.xyz.select(3, 0).add_(0.5);
  g.rgba.select(0, 1).copy_(g.xyz.select(3, 0) * g.mask);  // green varies along x: the colour must move too
  Eigen::Matrix4d m;
  const RegGrid h = MirrorRegGrid(g, &m);
  EXPECT_NO_THROW(h.Check());
  EXPECT_DOUBLE_EQ(m(0, 0), -1);
  EXPECT_DOUBLE_EQ(m(0, 3), 1.0);  // x -> 1 - x
  EXPECT_TRUE((m * m).isIdentity(1e-12));
  EXPECT_EQ(h.mask.sum().item<std::int64_t>(), g.mask.sum().item<std::int64_t>());
  const Eigen::Vector3d c = MaskedCentroid(g), ch = MaskedCentroid(h);
  EXPECT_NEAR(ch.x(), 1.0 - c.x(), 1e-5);
  EXPECT_NEAR(ch.y(), c.y(), 1e-5);
  EXPECT_NEAR(ch.z(), c.z(), 1e-5);
  // Each voxel's colour travels with its sample point: green was x before, so it is 1 - x now.
  const auto hx = h.xyz.select(3, 0).masked_select(h.mask);
  const auto hg = h.rgba.select(0, 1).masked_select(h.mask);
  EXPECT_LT((hg - (1 - hx)).abs().max().item<float>(), 1e-5);
  // Twice is the identity.
  const RegGrid back = MirrorRegGrid(h);
  EXPECT_TRUE(back.mask.equal(g.mask));
  EXPECT_TRUE(back.rgba.equal(g.rgba));
  EXPECT_LT((back.xyz - g.xyz).abs().max().item<float>(), 1e-6);
}

TEST(RegGrid, MirroredPairIsRelatedByTheConjugatedRotation) {
  const RegGrid g = BallGrid();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.1, -0.05, 0.2);
  const RegGrid h = TransformRegGrid(g, R, t);
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  target_from_source.topLeftCorner<3, 3>() = R;
  target_from_source.topRightCorner<3, 1>() = t;
  RegGrid gm = g, hm = h;
  Eigen::Matrix4d mirrored = target_from_source;
  MirrorRegGridPair(&gm, &hm, &mirrored);
  const Eigen::Matrix3d Rm = mirrored.topLeftCorner<3, 3>();
  EXPECT_NEAR(Rm.determinant(), 1.0, 1e-9);  // a rotation, not a reflection
  EXPECT_TRUE((Rm.transpose() * Rm).isIdentity(1e-9));
  // It carries the mirrored ball onto the mirrored moved ball (within the resampling's cell).
  const Eigen::Vector3d moved = (mirrored * MaskedCentroid(gm).homogeneous()).head<3>();
  EXPECT_LT((moved - MaskedCentroid(hm)).norm(), 2.0 / 16);
}

TEST(RegGrid, RecolourPermutesAndScalesColourOnly) {
  RegGrid g = BallGrid();  // red 0.7, green 0, blue 0 where masked
  g.rgba.select(0, 2).masked_fill_(g.mask, 0.2);
  const RegGrid h = RecolourRegGrid(g, {2, 0, 1}, {1.0, 2.0, 0.5});
  // new R = old B, new G = 2 old R (clamped to 1), new B = 0.5 old G
  EXPECT_TRUE(h.rgba.select(0, 0).equal(g.rgba.select(0, 2)));
  EXPECT_TRUE(h.rgba.select(0, 1).equal((g.rgba.select(0, 0) * 2).clamp(0, 1)));
  EXPECT_FLOAT_EQ(h.rgba.select(0, 1).max().item<float>(), 1.0f);
  EXPECT_FLOAT_EQ(h.rgba.select(0, 2).abs().max().item<float>(), 0.0f);
  EXPECT_TRUE(h.rgba.select(0, 3).equal(g.rgba.select(0, 3)));
  EXPECT_TRUE(h.mask.equal(g.mask));
  EXPECT_TRUE(h.xyz.equal(g.xyz));
  EXPECT_THROW(RecolourRegGrid(g, {0, 0, 1}, {1, 1, 1}), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
