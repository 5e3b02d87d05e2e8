#include "nerfreg/nerf/hash_encoding.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "nerfreg/util/torch_device.h"

namespace nerfreg {
namespace {

HashEncodingOptions SmallOptions(const std::string& rule = "nerfreg") {
  HashEncodingOptions o;
  o.grid_rule = rule;
  o.levels = 4;
  o.features = 2;
  o.log2_table_size = 10;  // coarse levels dense, fine levels hashed
  o.base_resolution = 4;
  o.per_level_scale = 2.5;
  return o;
}

// The fused kernel and the reference share one contract under both grid rules.
class HashEncodingRule : public ::testing::TestWithParam<std::string> {};
INSTANTIATE_TEST_SUITE_P(Rules, HashEncodingRule, ::testing::Values("nerfreg", "instant-ngp"));

TEST_P(HashEncodingRule, FusedForwardEqualsReference) {
  torch::manual_seed(1);
  const auto o = SmallOptions(GetParam());
  const auto table = torch::randn({o.levels, o.TableSize(), o.features});
  const auto x = torch::rand({300, 3});
  const auto a = HashEncode(x, table, o), b = HashEncodeReference(x, table, o);
  ASSERT_EQ(a.sizes(), b.sizes());
  EXPECT_LT((a - b).abs().max().item<float>(), 1e-5);
  // Both kinds of level are exercised.
  EXPECT_LE(std::pow(LevelResolution(o, 0) + 1, 3), o.TableSize());
  EXPECT_GT(std::pow(LevelResolution(o, 3) + 1, 3), o.TableSize());
}

TEST_P(HashEncodingRule, FusedBackwardEqualsReferenceAndFiniteDifferences) {
  torch::manual_seed(2);
  auto o = SmallOptions(GetParam());
  o.log2_table_size = 6;  // small table: many collisions, so scatter-adds must accumulate
  const auto x = torch::rand({200, 3});
  const auto w = torch::randn({200, o.OutputDim()});
  auto t1 = (torch::randn({o.levels, o.TableSize(), o.features}) * 0.1).requires_grad_(true);
  auto t2 = t1.detach().clone().requires_grad_(true);
  (HashEncode(x, t1, o) * w).sum().backward();
  (HashEncodeReference(x, t2, o) * w).sum().backward();
  EXPECT_LT((t1.grad() - t2.grad()).abs().max().item<float>(), 1e-4);
  EXPECT_GT(t1.grad().abs().sum().item<float>(), 1.0f);
  // Finite differences on a few entries (the output is linear in the table: exact up to float).
  auto td = t1.detach().to(torch::kFloat64);
  for (int k = 0; k < 5; ++k) {
    const int64_t l = k % o.levels, i = (k * 7) % o.TableSize(), f = k % o.features;
    const double eps = 1e-3;
    auto plus = td.clone(), minus = td.clone();
    plus[l][i][f] += eps;
    minus[l][i][f] -= eps;
    const double fd = ((HashEncode(x, plus.to(torch::kFloat32), o) * w).sum().item<double>() -
                       (HashEncode(x, minus.to(torch::kFloat32), o) * w).sum().item<double>()) /
                      (2 * eps);
    EXPECT_NEAR(fd, t1.grad()[l][i][f].item<double>(), 2e-2 + 1e-2 * std::abs(fd));
  }
}

TEST_P(HashEncodingRule, FusedHandlesAnyPointCountAndOutOfRangePositions) {
  // The kernels work on groups of points: counts around the group size, and positions outside
  // [0, 1] (clamped), must match the reference.
  torch::manual_seed(5);
  const auto o = SmallOptions(GetParam());
  const auto table = torch::randn({o.levels, o.TableSize(), o.features});
  for (std::int64_t n : {0, 1, 7, 8, 9, 17}) {
    const auto x = torch::rand({n, 3}) * 1.4 - 0.2;
    auto t1 = table.clone().requires_grad_(true), t2 = table.clone().requires_grad_(true);
    const auto a = HashEncode(x, t1, o), b = HashEncodeReference(x, t2, o);
    ASSERT_EQ(a.sizes(), b.sizes()) << n;
    if (n == 0) continue;
    EXPECT_LT((a - b).abs().max().item<float>(), 1e-5) << n;
    a.sum().backward();
    b.sum().backward();
    EXPECT_LT((t1.grad() - t2.grad()).abs().max().item<float>(), 1e-5) << n;
  }
}

TEST(HashEncoding, InterpolatesGridValuesExactlyAtVertices) {
  // A point on a level-0 grid vertex reads exactly that vertex's feature.
  auto o = SmallOptions();
  o.levels = 1;
  const auto table = torch::randn({1, o.TableSize(), o.features});
  const int res = LevelResolution(o, 0);
  // pos = x * (res - 1) + 0.5 = 2.0 + 0.5 -> vertex floor 2 with weight 0.5: use x so pos is integral.
  const float x0 = 1.5f / (res - 1);  // pos = 2.0
  const auto x = torch::tensor({{x0, x0, x0}});
  const auto out = HashEncode(x, table, o);
  const int64_t idx = 2 + 2 * (res + 1) + 2 * (res + 1) * (res + 1);
  EXPECT_NEAR(out[0][0].item<float>(), table[0][idx][0].item<float>(), 1e-5);
}

TEST(HashEncoding, InstantNgpRuleLevelsAndWrappingDenseIndex) {
  // tiny-cuda-nn: scale = 2.5^l * 4 - 1 = 3, 9, 24, 61.5 -> resolution ceil + 1 = 4, 10, 25, 63.
  const auto o = SmallOptions("instant-ngp");
  EXPECT_EQ(LevelResolution(o, 0), 4);
  EXPECT_EQ(LevelResolution(o, 1), 10);
  EXPECT_EQ(LevelResolution(o, 3), 63);
  // Level 0 (4^3 = 64 rows, stride 4): x = 1 gives pos = 3 + 0.5 on every axis, so the 8 corners
  // (3|4, 3|4, 3|4) weigh 1/8 each, and vertex 4 wraps: index (x + 4y + 16z) mod 64.
  auto one = o;
  one.levels = 1;
  const auto table = torch::randn({1, one.TableSize(), one.features});
  const auto out = HashEncode(torch::tensor({{1.0f, 1.0f, 1.0f}}), table, one);
  auto expected = torch::zeros({one.features});
  for (int c = 0; c < 8; ++c) {
    const int x = 3 + (c & 1), y = 3 + ((c >> 1) & 1), z = 3 + ((c >> 2) & 1);
    expected += table[0][(x + 4 * y + 16 * z) % 64] / 8;
  }
  EXPECT_LT((out[0] - expected).abs().max().item<float>(), 1e-5);
  // Level 1 has 10^3 = 1000 rows (dense, not a power of 2): a vertex reads row x + 10y + 100z.
  auto second = o;
  second.levels = 2;
  const auto t2 = torch::randn({2, second.TableSize(), second.features});
  const float x0 = 4.5f / 9.0f;  // pos = 9 * x0 + 0.5 = 5 exactly
  const auto out2 = HashEncode(torch::tensor({{x0, x0, x0}}), t2, second);
  EXPECT_NEAR(out2[0][2].item<float>(), t2[1][5 + 50 + 500][0].item<float>(), 1e-5);
}

// The kernel of each device against the torch-ops reference on the CPU (the oracle), under both
// grid rules and at the paper's level count. CUDA cases skip where no GPU is present.
class HashEncodingDevice : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {
 protected:
  // "cuda" as cuda:0: tensors report their device with its index, and so must the expectation.
  torch::Device Device() const {
    return std::get<0>(GetParam()) == "cuda" ? torch::Device(torch::kCUDA, 0) : torch::Device(torch::kCPU);
  }
  void SetUp() override {
    if (std::get<0>(GetParam()) == "cuda" && !CudaAvailable()) {
      GTEST_SKIP() << "no CUDA device (this build's LibTorch has no CUDA or the machine has no GPU)";
    }
  }
};
INSTANTIATE_TEST_SUITE_P(Devices, HashEncodingDevice,
                         ::testing::Combine(::testing::Values("cpu", "cuda"),
                                            ::testing::Values("nerfreg", "instant-ngp")),
                         [](const ::testing::TestParamInfo<HashEncodingDevice::ParamType>& info) {
                           std::string name = std::get<0>(info.param) + "_" + std::get<1>(info.param);
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;  // e.g. cuda_instant_ngp (scripts/gpu_check.sh filters on it)
                         });

TEST_P(HashEncodingDevice, KernelMatchesCpuReferenceForwardAndBackward) {
  torch::manual_seed(11);
  auto o = SmallOptions(std::get<1>(GetParam()));
  o.levels = 16;
  o.per_level_scale = 1.3;
  o.log2_table_size = 12;  // coarse levels dense, the fine ones hashed with many collisions
  const std::int64_t n = 5000;
  const auto x = torch::rand({n, 3}) * 1.2 - 0.1;
  const auto w = torch::randn({n, o.OutputDim()});
  const auto table = torch::randn({o.levels, o.TableSize(), o.features}) * 0.1;
  auto t_ref = table.clone().requires_grad_(true);
  const auto ref = HashEncodeReference(x, t_ref, o);
  (ref * w).sum().backward();

  const torch::Device device = Device();
  EXPECT_TRUE(HashEncodeHasKernel(device));
  auto t_dev = table.to(device).requires_grad_(true);
  const auto out = HashEncode(x.to(device), t_dev, o);
  ASSERT_EQ(out.device(), device);
  (out * w.to(device)).sum().backward();
  EXPECT_LT((out.cpu() - ref).abs().max().item<float>(), 1e-5);
  ASSERT_TRUE(t_dev.grad().defined());
  EXPECT_EQ(t_dev.grad().device(), device);
  // Scatter-adds in another order: equal to float rounding of the sums.
  EXPECT_LT((t_dev.grad().cpu() - t_ref.grad()).abs().max().item<float>(), 1e-3);
  EXPECT_GT(t_ref.grad().abs().sum().item<float>(), 1.0f);
}

}  // namespace
}  // namespace nerfreg
