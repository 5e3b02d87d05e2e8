#include "nerfreg/nerf/volume_rendering.h"

#include <gtest/gtest.h>

#include "nerfreg/nerf/field.h"

namespace nerfreg {
namespace {

TEST(VolumeRendering, FusedCompositeEqualsReferenceForwardAndBackward) {
  torch::manual_seed(3);
  // 5 rays with 0..40 samples each, densities high enough that some rays terminate early.
  std::vector<std::int64_t> counts = {0, 3, 40, 17, 25};
  std::vector<std::int64_t> off = {0};
  for (auto c : counts) off.push_back(off.back() + c);
  const std::int64_t S = off.back();
  const auto offsets = torch::tensor(off);
  auto t_starts = torch::rand({S}) * 2, t_ends = t_starts + 0.05;
  auto s1 = (torch::rand({S}) * 60).requires_grad_(true), c1 = torch::rand({S, 3}).requires_grad_(true);
  auto s2 = s1.detach().clone().requires_grad_(true), c2 = c1.detach().clone().requires_grad_(true);
  const auto a = Composite(s1, c1, t_starts, t_ends, offsets);
  const auto b = CompositeReference(s2, c2, t_starts, t_ends, offsets);
  EXPECT_LT((a.rgb - b.rgb).abs().max().item<float>(), 1e-5);
  EXPECT_LT((a.opacity - b.opacity).abs().max().item<float>(), 1e-5);
  EXPECT_LT((a.depth - b.depth).abs().max().item<float>(), 1e-4);
  EXPECT_EQ(a.opacity[0].item<float>(), 0.f);  // a ray without samples
  const auto w1 = torch::randn({5, 3}), w2 = torch::randn({5}), w3 = torch::randn({5});
  ((a.rgb * w1).sum() + (a.opacity * w2).sum() + (a.depth * w3).sum()).backward();
  ((b.rgb * w1).sum() + (b.opacity * w2).sum() + (b.depth * w3).sum()).backward();
  EXPECT_LT((s1.grad() - s2.grad()).abs().max().item<float>(), 1e-4);
  EXPECT_LT((c1.grad() - c2.grad()).abs().max().item<float>(), 1e-5);
  EXPECT_GT(s1.grad().abs().sum().item<float>(), 0.f);
}

TEST(VolumeRendering, CompositeGradientMatchesFiniteDifferences) {
  torch::manual_seed(4);
  const auto offsets = torch::tensor(std::vector<std::int64_t>{0, 12});
  const auto t_starts = torch::linspace(0, 1.1, 12), t_ends = t_starts + 0.1;
  auto sig = (torch::rand({12}) * 3).to(torch::kFloat32).requires_grad_(true);
  const auto rgb = torch::rand({12, 3});
  const auto w = torch::randn({1, 3});
  (Composite(sig, rgb, t_starts, t_ends, offsets).rgb * w).sum().backward();
  for (int i = 0; i < 12; i += 3) {
    auto p = sig.detach().clone(), m = sig.detach().clone();
    const float eps = 1e-2f;
    p[i] += eps;
    m[i] -= eps;
    const float fd = ((Composite(p, rgb, t_starts, t_ends, offsets).rgb * w).sum().item<float>() -
                      (Composite(m, rgb, t_starts, t_ends, offsets).rgb * w).sum().item<float>()) /
                     (2 * eps);
    EXPECT_NEAR(sig.grad()[i].item<float>(), fd, 2e-3) << i;
  }
}

TEST(VolumeRendering, MarchingSkipsEmptySpace) {
  OccupancyGridOptions go;
  go.resolution = 16;
  OccupancyGrid grid(go, {-1.5, -1.5, -1.5}, {1.5, 1.5, 1.5});
  // Before any update everything is occupied: a ray through the box gets samples all along it.
  const auto o = torch::tensor({{-3.f, 0.1f, 0.1f}, {-3.f, 2.5f, 0.f}});
  const auto d = torch::tensor({{1.f, 0.f, 0.f}, {1.f, 0.f, 0.f}});
  MarchOptions mo;
  mo.step_size = 0.01;
  auto s = MarchRays(o, d, grid, mo);
  EXPECT_NEAR(s.offsets[1].item<std::int64_t>(), 300, 2);
  EXPECT_EQ(s.offsets[2].item<std::int64_t>(), s.offsets[1].item<std::int64_t>());  // ray 2 misses the box
  // A field that is dense only inside a ball of radius 0.5: after an update, samples stay near it.
  auto density_fn = [](const torch::Tensor& x) { return (x.norm(2, 1) < 0.5).to(torch::kFloat32) * 100.f; };
  grid.Update(0, mo.step_size, density_fn);
  EXPECT_LT(grid.OccupiedFraction(), 0.1);
  s = MarchRays(o, d, grid, mo);
  const auto t = s.t_starts.slice(0, 0, s.offsets[1].item<std::int64_t>());
  ASSERT_GT(t.numel(), 50);
  EXPECT_GT(t.min().item<float>(), 3.f - 0.5f - 2 * 3.f / 16);  // within a cell of the ball
  EXPECT_LT(t.max().item<float>(), 3.f + 0.5f + 2 * 3.f / 16);
}

TEST(Field, ShapesAndFiniteGradients) {
  FieldOptions fo;
  fo.encoding.log2_table_size = 12;
  NerfField field(fo);
  const auto x = torch::rand({64, 3}) * 3 - 1.5, d = torch::nn::functional::normalize(torch::randn({64, 3}));
  auto [sigma, rgb] = field->Forward(x, d);
  EXPECT_EQ(sigma.sizes(), torch::IntArrayRef({64}));
  EXPECT_EQ(rgb.sizes(), torch::IntArrayRef({64, 3}));
  (sigma.sum() + rgb.sum()).backward();
  for (const auto& p : field->parameters()) {
    ASSERT_TRUE(p.grad().defined());
    EXPECT_TRUE(torch::isfinite(p.grad()).all().item<bool>());
  }
  EXPECT_EQ(field->Density(torch::tensor({{2.f, 0.f, 0.f}}))[0].item<float>(), 0.f);  // outside the AABB
  // SH: the degree-0 coefficient is constant and degree 1 is linear in the direction.
  const auto sh = SphericalHarmonics16(torch::tensor({{0.f, 0.f, 1.f}}));
  EXPECT_NEAR(sh[0][0].item<float>(), 0.2820948f, 1e-6);
  EXPECT_NEAR(sh[0][2].item<float>(), 0.4886025f, 1e-6);
}

}  // namespace
}  // namespace nerfreg
