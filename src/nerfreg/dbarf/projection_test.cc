#include "nerfreg/dbarf/projection.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nerfreg {
namespace {

torch::Tensor Intrinsics(double f, double cx, double cy) {
  return torch::tensor({f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0}, torch::kFloat).view({1, 3, 3});
}

// cam_from_world of a camera with rotation R (row-major 9 values) at world centre c.
torch::Tensor CamFromWorld(const std::vector<double>& r9, const std::vector<double>& c) {
  const torch::Tensor r = torch::tensor(r9, torch::kDouble).view({3, 3});
  const torch::Tensor t = -torch::matmul(r, torch::tensor(c, torch::kDouble));
  torch::Tensor m = torch::eye(4, torch::kDouble);
  m.narrow(0, 0, 3).narrow(1, 0, 3).copy_(r);
  m.narrow(0, 0, 3).select(1, 3).copy_(t);
  return m.to(torch::kFloat).unsqueeze(0);
}

const std::vector<double> kIdentity = {1, 0, 0, 0, 1, 0, 0, 0, 1};

TEST(Projection, KnownPointsLandOnKnownPixels) {
  // Camera rotated 90 degrees about z (x_cam = (-y, x, z) + t), centred at (1, 2, -3).
  const torch::Tensor k = torch::cat({Intrinsics(100, 32, 24), Intrinsics(50, 10, 20)});
  const torch::Tensor pose =
      torch::cat({CamFromWorld(kIdentity, {0, 0, 0}), CamFromWorld({0, -1, 0, 1, 0, 0, 0, 0, 1}, {1, 2, -3})});
  const torch::Tensor pts = torch::tensor({0.1, -0.2, 2.0, 1.0, 2.5, 1.0}, torch::kFloat).view({1, 2, 3});
  const ProjectedPoints p = ProjectToViews(pts, k, pose, 48, 64);
  ASSERT_EQ(p.uv.sizes(), torch::IntArrayRef({2, 1, 2, 2}));
  // View 0: (100 * 0.1 / 2 + 32, 100 * -0.2 / 2 + 24) = (37, 14); (100 / 1 + 32, 250 + 24).
  EXPECT_NEAR(p.uv[0][0][0][0].item<double>(), 37.0, 1e-4);
  EXPECT_NEAR(p.uv[0][0][0][1].item<double>(), 14.0, 1e-4);
  EXPECT_NEAR(p.uv[0][0][1][0].item<double>(), 132.0, 1e-4);
  // View 1, point 0: x - c = (-0.9, -2.2, 5) -> x_cam = (2.2, -0.9, 5) -> (50*0.44+10, 50*-0.18+20).
  EXPECT_NEAR(p.uv[1][0][0][0].item<double>(), 32.0, 1e-4);
  EXPECT_NEAR(p.uv[1][0][0][1].item<double>(), 11.0, 1e-4);
  // Point 1 in view 1: x - c = (0, 0.5, 4) -> x_cam = (-0.5, 0, 4) -> (3.75, 20).
  EXPECT_NEAR(p.uv[1][0][1][0].item<double>(), 3.75, 1e-4);
  EXPECT_NEAR(p.uv[1][0][1][1].item<double>(), 20.0, 1e-4);
  EXPECT_TRUE(p.in_front.all().item<bool>());
  EXPECT_TRUE(p.in_bounds[0][0][0].item<bool>());
  EXPECT_FALSE(p.in_bounds[0][0][1].item<bool>());  // u = 132 > 64
  EXPECT_TRUE(p.in_bounds[1].all().item<bool>());
}

TEST(Projection, BehindCameraAndBoundsMasks) {
  const torch::Tensor k = Intrinsics(8, 8, 6);
  const torch::Tensor pose = CamFromWorld(kIdentity, {0, 0, 0});
  // In front and centred; behind (z < 0); on the image border u = W exactly (inside);
  // just outside the border (v = -0.4 < 0).
  const torch::Tensor pts =
      torch::tensor({0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 1.0, 0.0, 1.0, 0.0, -0.8, 1.0}, torch::kFloat).view({1, 4, 3});
  const ProjectedPoints p = ProjectToViews(pts, k, pose, 12, 16);
  const torch::Tensor front = p.in_front[0][0], bounds = p.in_bounds[0][0], valid = p.Valid()[0][0];
  EXPECT_TRUE(front[0].item<bool>() && bounds[0].item<bool>() && valid[0].item<bool>());
  EXPECT_FALSE(front[1].item<bool>());
  EXPECT_FALSE(valid[1].item<bool>());
  EXPECT_TRUE(torch::isfinite(p.uv).all().item<bool>());
  EXPECT_TRUE(bounds[2].item<bool>());   // u = 16 = W
  EXPECT_FALSE(bounds[3].item<bool>());  // v = -0.4
  EXPECT_TRUE(front[3].item<bool>());
}

TEST(Projection, SamplingAFrontoParallelPlaneReturnsItsTexture) {
  // A plane z = 2 with colour linear in (X, Y), seen by a source camera at the origin: the source
  // image (pixel centres) is the texture; points of the plane seen from a shifted target camera
  // project into the source and sampling there returns the texture (bilinear is exact on a linear
  // texture away from the border half-pixel).
  const int64_t h = 12, w = 16;
  const double f = 10, cx = 8, cy = 6, depth = 2;
  auto texture = [](const torch::Tensor& x, const torch::Tensor& y) {
    return torch::stack({0.5 + 0.3 * x, 0.5 - 0.2 * y, 0.3 + 0.1 * x + 0.2 * y}, -1);
  };
  const torch::Tensor col = torch::arange(w, torch::kFloat) + 0.5, row = torch::arange(h, torch::kFloat) + 0.5;
  const auto grid = torch::meshgrid({row, col}, "ij");
  const torch::Tensor image =
      texture((grid[1] - cx) / f * depth, (grid[0] - cy) / f * depth).permute({2, 0, 1}).unsqueeze(0);
  // Points on the plane, well inside the source view's interior.
  const torch::Tensor xy = torch::rand({5, 7, 2}) * torch::tensor({1.2, 0.8}) - torch::tensor({0.6, 0.4});
  const torch::Tensor pts = torch::cat({xy, torch::full({5, 7, 1}, depth)}, -1);
  const ProjectedPoints p = ProjectToViews(pts, Intrinsics(f, cx, cy), CamFromWorld(kIdentity, {0, 0, 0}), h, w);
  ASSERT_TRUE(p.Valid().all().item<bool>());
  const torch::Tensor sampled = SampleViews(image, p.uv, h, w);  // [1,5,7,3]
  const torch::Tensor expected = texture(xy.select(2, 0), xy.select(2, 1));
  EXPECT_LT((sampled[0] - expected).abs().max().item<double>(), 1e-5);

  // A quarter-resolution map (4x4 cells of the 16x12 image) of a function linear in (u, v) is
  // sampled with the same image coordinates.
  const torch::Tensor fc = torch::arange(4, torch::kFloat) * 4 + 2, fr = torch::arange(3, torch::kFloat) * 4 + 2;
  const auto fg = torch::meshgrid({fr, fc}, "ij");
  const torch::Tensor fmap = (0.1 * fg[1] - 0.05 * fg[0]).view({1, 1, 3, 4});
  const torch::Tensor uv = torch::tensor({5.0, 4.0, 9.5, 7.0}, torch::kFloat).view({1, 1, 2, 2});
  const torch::Tensor got = SampleViews(fmap, uv, h, w);
  EXPECT_NEAR(got[0][0][0][0].item<double>(), 0.1 * 5.0 - 0.05 * 4.0, 1e-5);
  EXPECT_NEAR(got[0][0][1][0].item<double>(), 0.1 * 9.5 - 0.05 * 7.0, 1e-5);
  // Far outside: zero padding.
  const torch::Tensor outside = SampleViews(image, torch::full({1, 1, 1, 2}, -50.0), h, w);
  EXPECT_EQ(outside.abs().max().item<double>(), 0.0);
}

TEST(Projection, CameraCentresAndRayDifference) {
  const torch::Tensor pose =
      torch::cat({CamFromWorld({0, -1, 0, 1, 0, 0, 0, 0, 1}, {1, 2, -3}), CamFromWorld(kIdentity, {2, 0, -2})});
  const torch::Tensor c = CameraCenters(pose);
  EXPECT_LT((c[0] - torch::tensor({1.0, 2.0, -3.0})).abs().max().item<double>(), 1e-5);

  // Point at the origin, query camera at (0, 0, -2): a = (0, 0, -1); source at (2, 0, -2):
  // b = (1, 0, -1) / sqrt(2); the same centre as the query: a == b.
  const torch::Tensor pts = torch::zeros({1, 1, 3});
  const torch::Tensor query = torch::tensor({0.0, 0.0, -2.0}, torch::kFloat).view({1, 3});
  const torch::Tensor sources = torch::tensor({2.0, 0.0, -2.0, 0.0, 0.0, -2.0}, torch::kFloat).view({2, 3});
  const torch::Tensor d = RayDifference(pts, query, sources);
  ASSERT_EQ(d.sizes(), torch::IntArrayRef({2, 1, 1, 4}));
  const double s = 1.0 / std::sqrt(2.0);
  const double dx = -s, dz = -1.0 + s, n = std::sqrt(dx * dx + dz * dz);
  EXPECT_NEAR(d[0][0][0][0].item<double>(), dx / n, 1e-4);
  EXPECT_NEAR(d[0][0][0][1].item<double>(), 0.0, 1e-6);
  EXPECT_NEAR(d[0][0][0][2].item<double>(), dz / n, 1e-4);
  EXPECT_NEAR(d[0][0][0][3].item<double>(), s, 1e-5);
  EXPECT_LT(d[1][0][0].narrow(0, 0, 3).abs().max().item<double>(), 1e-6);
  EXPECT_NEAR(d[1][0][0][3].item<double>(), 1.0, 1e-5);
}

TEST(Projection, GradientsReachPointsAndPoses) {
  const torch::Tensor pose = CamFromWorld(kIdentity, {0.1, 0, -1}).requires_grad_(true);
  const torch::Tensor pts = (torch::rand({3, 4, 3}) * 0.5 + torch::tensor({0.0, 0.0, 1.0})).requires_grad_(true);
  const ProjectedPoints p = ProjectToViews(pts, Intrinsics(10, 8, 6), pose, 12, 16);
  const torch::Tensor image = torch::rand({1, 3, 12, 16});
  SampleViews(image, p.uv, 12, 16).sum().backward();
  ASSERT_TRUE(pose.grad().defined() && pts.grad().defined());
  EXPECT_TRUE(torch::isfinite(pose.grad()).all().item<bool>());
  EXPECT_GT(pose.grad().abs().sum().item<double>(), 0.0);
  EXPECT_GT(pts.grad().abs().sum().item<double>(), 0.0);
}

TEST(Projection, PoseAndPointGradientsEqualFiniteDifferences) {
  // In float64: d/d(pose, points) of sum(c * sampled image) + sum(c' * ray difference).
  torch::manual_seed(12);
  const torch::Tensor k = Intrinsics(10, 8, 6).to(torch::kDouble);
  const torch::Tensor pose0 =
      CamFromWorld({0.995, -0.0998, 0, 0.0998, 0.995, 0, 0, 0, 1}, {0.1, 0, -1}).to(torch::kDouble);
  const torch::Tensor pts0 =
      torch::rand({3, 4, 3}, torch::kDouble) * 0.5 + torch::tensor({0.0, 0.0, 1.0}, torch::kDouble);
  const torch::Tensor image = torch::rand({1, 2, 12, 16}, torch::kDouble);
  const torch::Tensor c = torch::rand({1, 3, 4, 2}, torch::kDouble), c2 = torch::rand({1, 3, 4, 4}, torch::kDouble);
  const torch::Tensor query = torch::tensor({0.3, -0.2, -0.5}, torch::kDouble).expand({3, 3});
  auto objective = [&](const torch::Tensor& pose, const torch::Tensor& pts) {
    const ProjectedPoints p = ProjectToViews(pts, k, pose, 12, 16);
    const torch::Tensor diff = RayDifference(pts, query, CameraCenters(pose));
    return (SampleViews(image, p.uv, 12, 16) * c).sum() + (diff * c2).sum();
  };
  const torch::Tensor pose = pose0.clone().requires_grad_(true), pts = pts0.clone().requires_grad_(true);
  objective(pose, pts).backward();
  const double eps = 1e-6;
  for (int64_t i = 0; i < 3; ++i) {
    for (int64_t j = 0; j < 4; ++j) {
      torch::Tensor plus = pose0.clone(), minus = pose0.clone();
      plus[0][i][j] += eps;
      minus[0][i][j] -= eps;
      const double fd = (objective(plus, pts0) - objective(minus, pts0)).item<double>() / (2 * eps);
      EXPECT_NEAR(pose.grad()[0][i][j].item<double>(), fd, 1e-5 * (1 + std::abs(fd))) << i << "," << j;
    }
  }
  for (int64_t d = 0; d < 3; ++d) {
    torch::Tensor plus = pts0.clone(), minus = pts0.clone();
    plus[1][2][d] += eps;
    minus[1][2][d] -= eps;
    const double fd = (objective(pose0, plus) - objective(pose0, minus)).item<double>() / (2 * eps);
    EXPECT_NEAR(pts.grad()[1][2][d].item<double>(), fd, 1e-5 * (1 + std::abs(fd))) << d;
  }
}

}  // namespace
}  // namespace nerfreg
