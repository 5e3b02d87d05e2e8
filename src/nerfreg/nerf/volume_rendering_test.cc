#include "nerfreg/nerf/volume_rendering.h"

#include <ATen/CPUGeneratorImpl.h>
#include <gtest/gtest.h>

#include "nerfreg/nerf/field.h"
#include "nerfreg/util/torch_device.h"

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

// The kernels of each device against the CPU kernels and the torch-ops reference. The CUDA cases
// skip where no GPU is present (scripts/gpu_check.sh runs them alone and wants them to pass).
class VolumeRenderingDevice : public ::testing::TestWithParam<std::string> {
 protected:
  // "cuda" as cuda:0: tensors report their device with its index, and so must the expectation.
  torch::Device Device() const {
    return GetParam() == "cuda" ? torch::Device(torch::kCUDA, 0) : torch::Device(torch::kCPU);
  }
  void SetUp() override {
    if (GetParam() == "cuda" && !CudaAvailable()) {
      GTEST_SKIP() << "no CUDA device (this build's LibTorch has no CUDA or the machine has no GPU)";
    }
  }
};
INSTANTIATE_TEST_SUITE_P(Devices, VolumeRenderingDevice, ::testing::Values("cpu", "cuda"),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

// A box of half-width 0.5 in the cube [-1, 1]^3: at 16 cells its faces lie on cell faces, so each
// cell is empty or full whatever point of it the update samples.
torch::Tensor BoxDensity(const torch::Tensor& x) {  // x [N, 3] -> [N]
  return (x.abs().amax(1) < 0.5).to(torch::kFloat32) * 100.f;
}

TEST_P(VolumeRenderingDevice, CompositeMatchesCpuKernelAndReferenceForwardAndBackward) {
  torch::manual_seed(21);
  // 300 rays with 0..79 samples, densities high enough that many rays stop early.
  const auto counts = torch::randint(80, {300}, torch::kInt64);
  const auto offsets = torch::cat({torch::zeros({1}, torch::kInt64), counts.cumsum(0)});  // [R + 1]
  const std::int64_t R = counts.numel(), S = offsets[R].item<std::int64_t>();
  const auto t_starts = torch::rand({S}) * 2, t_ends = t_starts + 0.05;
  const auto sigmas = torch::rand({S}) * 60, rgbs = torch::rand({S, 3});
  const auto w_rgb = torch::randn({R, 3}), w_opacity = torch::randn({R}), w_depth = torch::randn({R});
  auto loss = [&](const CompositeResult& c, const torch::Device& d) {
    return (c.rgb * w_rgb.to(d)).sum() + (c.opacity * w_opacity.to(d)).sum() + (c.depth * w_depth.to(d)).sum();
  };
  struct Run {
    CompositeResult out;
    torch::Tensor grad_sigmas, grad_rgbs;
  };
  auto run = [&](const torch::Device& d, bool reference) {
    // Copies: to(kCPU) of a CPU tensor is that tensor, so requires_grad_ would mark the shared input
    // and make the next run's to(cuda) a non-leaf without a .grad().
    auto s = sigmas.to(d, false, true).requires_grad_(true), c = rgbs.to(d, false, true).requires_grad_(true);
    const auto out = reference ? CompositeReference(s, c, t_starts.to(d), t_ends.to(d), offsets.to(d))
                               : Composite(s, c, t_starts.to(d), t_ends.to(d), offsets.to(d));
    loss(out, d).backward();
    return Run{out, s.grad(), c.grad()};
  };
  const Run cpu = run(torch::kCPU, false), ref = run(torch::kCPU, true);
  const torch::Device device = Device();
  EXPECT_TRUE(CompositeHasKernel(device));
  const Run dev = run(device, false);
  ASSERT_EQ(dev.out.rgb.device(), device);
  ASSERT_EQ(dev.grad_sigmas.device(), device);
  // Against the CPU kernel: the same loop, float rounding apart (FMAs, expf's last bits).
  EXPECT_TRUE(torch::allclose(dev.out.rgb.cpu(), cpu.out.rgb, 0, 1e-5));
  EXPECT_TRUE(torch::allclose(dev.out.opacity.cpu(), cpu.out.opacity, 0, 1e-5));
  EXPECT_TRUE(torch::allclose(dev.out.depth.cpu(), cpu.out.depth, 0, 1e-4));
  EXPECT_TRUE(torch::allclose(dev.grad_sigmas.cpu(), cpu.grad_sigmas, 0, 1e-4));
  EXPECT_TRUE(torch::allclose(dev.grad_rgbs.cpu(), cpu.grad_rgbs, 0, 1e-5));
  // Against the torch-ops reference (autograd through cumprod): the fused test's tolerances.
  EXPECT_LT((dev.out.rgb.cpu() - ref.out.rgb).abs().max().item<float>(), 1e-5);
  EXPECT_LT((dev.out.opacity.cpu() - ref.out.opacity).abs().max().item<float>(), 1e-5);
  EXPECT_LT((dev.out.depth.cpu() - ref.out.depth).abs().max().item<float>(), 1e-4);
  EXPECT_LT((dev.grad_sigmas.cpu() - ref.grad_sigmas).abs().max().item<float>(), 1e-4);
  EXPECT_LT((dev.grad_rgbs.cpu() - ref.grad_rgbs).abs().max().item<float>(), 1e-5);
  // Not vacuous: rays stopped early (their last samples get no gradient), gradients flowed.
  const auto stopped = (ref.grad_rgbs.abs().sum(1) == 0).sum().item<std::int64_t>();
  EXPECT_GT(stopped, S / 10);
  EXPECT_GT(ref.grad_sigmas.abs().sum().item<float>(), 1.f);
}

TEST_P(VolumeRenderingDevice, MarchGivesTheCpuSamples) {
  torch::manual_seed(22);
  OccupancyGridOptions go;
  go.resolution = 16;
  OccupancyGrid grid(go, {-1, -1, -1}, {1, 1, 1});
  grid.Update(0, 0.01, BoxDensity);
  ASSERT_LT(grid.OccupiedFraction(), 0.2);
  // Rays from a shell around the cube towards points near the box, some missing the cube, and
  // rays starting inside it.
  const std::int64_t R = 500;
  auto origins = torch::nn::functional::normalize(torch::randn({R, 3})) * 2.5;
  origins.slice(0, 0, 50).copy_(torch::rand({50, 3}) - 0.5);
  const auto dirs = torch::nn::functional::normalize(torch::rand({R, 3}) * 1.6 - 0.8 - origins);
  const torch::Device device = Device();
  MarchOptions mo;
  mo.step_size = 0.01;
  mo.max_samples_per_ray = 60;  // shorter than the box (100 steps across): some rays are cut
  for (const bool perturb : {false, true}) {
    mo.perturb = perturb;
    torch::Generator g_cpu = at::detail::createCPUGenerator(7), g_dev = at::detail::createCPUGenerator(7);
    const RaySamples cpu = MarchRays(origins, dirs, grid, mo, g_cpu);
    const RaySamples dev = MarchRays(origins.to(device), dirs.to(device), grid, mo, g_dev);
    ASSERT_EQ(dev.t_starts.device(), device);
    ASSERT_EQ(dev.offsets.device(), device);
    // The same samples: offsets and ray ids equal, positions to float rounding (bit-equal expected:
    // the CUDA march rounds every operation as the CPU does).
    ASSERT_TRUE(torch::equal(dev.offsets.cpu(), cpu.offsets)) << "perturb " << perturb;
    EXPECT_TRUE(torch::equal(dev.ray_ids.cpu(), cpu.ray_ids));
    EXPECT_LE((dev.t_starts.cpu() - cpu.t_starts).abs().max().item<float>(), 1e-6f);
    EXPECT_LE((dev.t_ends.cpu() - cpu.t_ends).abs().max().item<float>(), 1e-6f);
    // Not vacuous: many rays hit the box, some missed everything, some were cut at the maximum.
    const auto counts = cpu.offsets.slice(0, 1) - cpu.offsets.slice(0, 0, -1);
    EXPECT_GT((counts > 0).sum().item<std::int64_t>(), R / 4);
    EXPECT_GT((counts == 0).sum().item<std::int64_t>(), 0);
    EXPECT_GT((counts == mo.max_samples_per_ray).sum().item<std::int64_t>(), 0);
  }
}

TEST_P(VolumeRenderingDevice, GridUpdateMatchesCpu) {
  OccupancyGridOptions go;
  go.resolution = 16;
  go.warmup_steps = 32;
  OccupancyGrid cpu(go, {-1, -1, -1}, {1, 1, 1}), dev(go, {-1, -1, -1}, {1, 1, 1});
  const torch::Device device = Device();
  dev.To(device);
  ASSERT_EQ(dev.device(), device);
  torch::Generator g_cpu = at::detail::createCPUGenerator(5), g_dev = at::detail::createCPUGenerator(5);
  // A density that moves: the box, then the box shifted by two cells (an EMA of both).
  for (const int step : {0, 32, 48}) {
    const double shift = step >= 32 ? 0.25 : 0.0;
    auto density_on = [&](const torch::Device& d) {
      return [&, d](const torch::Tensor& x) {
        EXPECT_EQ(x.device(), d);
        return BoxDensity(x - torch::tensor({shift, 0.0, 0.0}, x.options()));
      };
    };
    cpu.Update(step, 0.01, density_on(torch::kCPU), g_cpu);
    dev.Update(step, 0.01, density_on(device), g_dev);
    ASSERT_EQ(dev.density().device(), device);
    ASSERT_EQ(dev.occupied().device(), device);
    // The same cells at the same points: the EMA to float rounding (one multiply, one max), the
    // threshold's decisions equal (densities are 0 or 100 times 0.95^k, far from the threshold).
    EXPECT_TRUE(torch::allclose(dev.density().cpu(), cpu.density(), 1e-6, 0)) << "step " << step;
    EXPECT_TRUE(torch::equal(dev.occupied().cpu(), cpu.occupied())) << "step " << step;
  }
  // Not vacuous: both boxes were seen, the old one decays, the grid is neither empty nor full.
  EXPECT_GT(cpu.OccupiedFraction(), 0.05);
  EXPECT_LT(cpu.OccupiedFraction(), 0.3);
  EXPECT_TRUE(torch::equal(dev.CellCenters().cpu(), cpu.CellCenters()));
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
