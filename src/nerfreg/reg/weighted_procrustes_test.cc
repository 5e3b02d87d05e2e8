#include "nerfreg/util/torch_device.h"  // torch::linalg under LibTorch 2.x
#include "nerfreg/reg/weighted_procrustes.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nerfreg {
namespace {

torch::Tensor RandomRotation(torch::Dtype dtype) {
  auto q = torch::linalg::qr(torch::randn({3, 3}, torch::kDouble), "reduced");
  torch::Tensor r = std::get<0>(q);
  if (torch::linalg::det(r).item<double>() < 0) r = r * torch::tensor({1.0, 1.0, -1.0}, torch::kDouble);
  return r.to(dtype);
}

double TensorRotationErrorDeg(const torch::Tensor& a, const torch::Tensor& b) {
  const double tr = torch::trace(torch::matmul(a.transpose(0, 1), b)).item<double>();
  return std::acos(std::clamp((tr - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
}

class WeightedProcrustesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(2);
    torch::manual_seed(7);
  }
};

TEST_F(WeightedProcrustesTest, RecoversKnownRigidTransformWithOutliersZeroWeighted) {
  const torch::Tensor r = RandomRotation(torch::kFloat);
  const torch::Tensor t = torch::tensor({0.3f, -0.2f, 0.5f});
  const torch::Tensor src = torch::randn({60, 3});
  torch::Tensor tgt = torch::matmul(src, r.transpose(0, 1)) + t;
  // The last 20 correspondences are outliers with zero weight.
  tgt.slice(0, 40) = torch::randn({20, 3}) * 3.0;
  torch::Tensor w = torch::rand({60}) + 0.1;
  w.slice(0, 40) = 0.0;
  const auto res = WeightedProcrustes(src, tgt, w);
  EXPECT_TRUE(res.valid.item<bool>());
  EXPECT_LT(TensorRotationErrorDeg(res.rotation, r), 1e-3);
  EXPECT_LT((res.translation - t).norm().item<double>(), 1e-4);
  EXPECT_FLOAT_EQ(res.scale.item<float>(), 1.0f);
}

TEST_F(WeightedProcrustesTest, RecoversBatchedSim3) {
  const int64_t b = 4;
  std::vector<torch::Tensor> rs, srcs, tgts;
  const torch::Tensor scales = torch::tensor({0.5, 1.0, 1.7, 3.0}, torch::kDouble);
  const torch::Tensor ts = torch::randn({b, 3}, torch::kDouble);
  for (int64_t i = 0; i < b; ++i) {
    rs.push_back(RandomRotation(torch::kDouble));
    srcs.push_back(torch::randn({30, 3}, torch::kDouble));
    tgts.push_back(scales[i] * torch::matmul(srcs.back(), rs.back().t()) + ts[i]);
  }
  WeightedProcrustesOptions options;
  options.estimate_scale = true;
  const auto res =
      WeightedProcrustes(torch::stack(srcs), torch::stack(tgts), torch::rand({b, 30}, torch::kDouble) + 0.1, options);
  ASSERT_EQ(res.rotation.sizes(), (torch::IntArrayRef{b, 3, 3}));
  ASSERT_EQ(res.translation.sizes(), (torch::IntArrayRef{b, 3}));
  for (int64_t i = 0; i < b; ++i) {
    // The default regulariser (1e-7 relative) biases the rotation by ~1e-5 deg.
    EXPECT_LT(TensorRotationErrorDeg(res.rotation[i], rs[i]), 1e-4);
    EXPECT_NEAR(res.scale[i].item<double>(), scales[i].item<double>(), 1e-6);
    EXPECT_LT((res.translation[i] - ts[i]).norm().item<double>(), 1e-6);
  }
}

TEST_F(WeightedProcrustesTest, ReflectedTargetGivesProperRotation) {
  // tgt is a mirror image of src: the best orthogonal map has det -1; the solver must return
  // a proper rotation (det +1) instead.
  const torch::Tensor src = torch::randn({40, 3}, torch::kDouble);
  const torch::Tensor mirror = torch::diag(torch::tensor({1.0, 1.0, -1.0}, torch::kDouble));
  const torch::Tensor tgt = torch::matmul(src, mirror);
  const auto res = WeightedProcrustes(src, tgt, torch::ones({40}, torch::kDouble));
  EXPECT_NEAR(torch::linalg::det(res.rotation).item<double>(), 1.0, 1e-9);
  const torch::Tensor rtr = torch::matmul(res.rotation.t(), res.rotation);
  EXPECT_TRUE(torch::allclose(rtr, torch::eye(3, torch::kDouble), 1e-9, 1e-9));
}

TEST_F(WeightedProcrustesTest, DegenerateWeightsGiveIdentityInvalidAndFiniteGradients) {
  torch::Tensor src = torch::randn({2, 10, 3}).requires_grad_(true);
  torch::Tensor tgt = torch::randn({2, 10, 3}).requires_grad_(true);
  torch::Tensor w = torch::stack({torch::zeros({10}), torch::rand({10}) + 0.1}).requires_grad_(true);
  const auto res = WeightedProcrustes(src, tgt, w);
  EXPECT_FALSE(res.valid[0].item<bool>());
  EXPECT_TRUE(res.valid[1].item<bool>());
  EXPECT_TRUE(torch::equal(res.rotation[0], torch::eye(3)));
  EXPECT_TRUE(torch::equal(res.translation[0], torch::zeros({3})));
  (res.rotation.sum() + res.translation.sum()).backward();
  for (const auto& g : {src.grad(), tgt.grad(), w.grad()}) {
    ASSERT_TRUE(g.defined());
    EXPECT_TRUE(torch::isfinite(g).all().item<bool>());
  }
  EXPECT_EQ(w.grad()[0].abs().sum().item<float>(), 0.0f);
}

TEST_F(WeightedProcrustesTest, RankDeficientInputHasFiniteGradients) {
  // All weight on two points: the covariance has rank 1 (two zero singular values).
  torch::Tensor src = torch::randn({8, 3}).requires_grad_(true);
  torch::Tensor tgt = torch::randn({8, 3}).requires_grad_(true);
  torch::Tensor w = torch::zeros({8});
  w.slice(0, 0, 2) = 1.0;
  w.requires_grad_(true);
  const auto res = WeightedProcrustes(src, tgt, w);
  EXPECT_TRUE(res.valid.item<bool>());
  EXPECT_TRUE(torch::isfinite(res.rotation).all().item<bool>());
  (res.rotation.sum() + res.translation.sum()).backward();
  for (const auto& g : {src.grad(), tgt.grad(), w.grad()}) {
    EXPECT_TRUE(torch::isfinite(g).all().item<bool>());
  }
}

TEST_F(WeightedProcrustesTest, GradientMatchesFiniteDifferences) {
  WeightedProcrustesOptions options;
  options.regularizer = 0.0;
  options.estimate_scale = true;
  const torch::Tensor r = RandomRotation(torch::kDouble);
  const torch::Tensor src0 = torch::randn({12, 3}, torch::kDouble);
  const torch::Tensor tgt0 = torch::matmul(src0, r.t()) + 0.1 * torch::randn({12, 3}, torch::kDouble);
  const torch::Tensor w0 = torch::rand({12}, torch::kDouble) + 0.2;
  const torch::Tensor probe = torch::randn({3, 3}, torch::kDouble);
  auto objective = [&](const torch::Tensor& src, const torch::Tensor& tgt, const torch::Tensor& w) {
    const auto res = WeightedProcrustes(src, tgt, w, options);
    return (res.rotation * probe).sum() + res.translation.sum() + res.scale;
  };
  torch::Tensor src = src0.clone().requires_grad_(true);
  torch::Tensor tgt = tgt0.clone().requires_grad_(true);
  torch::Tensor w = w0.clone().requires_grad_(true);
  objective(src, tgt, w).backward();
  const double h = 1e-6;
  for (int64_t i = 0; i < 12; i += 3) {
    for (int64_t k = 0; k < 3; ++k) {
      torch::Tensor sp = src0.clone(), sm = src0.clone();
      sp[i][k] += h;
      sm[i][k] -= h;
      const double fd = (objective(sp, tgt0, w0) - objective(sm, tgt0, w0)).item<double>() / (2 * h);
      EXPECT_NEAR(src.grad()[i][k].item<double>(), fd, 1e-5 * (1.0 + std::abs(fd)));
      torch::Tensor tp = tgt0.clone(), tm = tgt0.clone();
      tp[i][k] += h;
      tm[i][k] -= h;
      const double fdt = (objective(src0, tp, w0) - objective(src0, tm, w0)).item<double>() / (2 * h);
      EXPECT_NEAR(tgt.grad()[i][k].item<double>(), fdt, 1e-5 * (1.0 + std::abs(fdt)));
    }
    torch::Tensor wp = w0.clone(), wm = w0.clone();
    wp[i] += h;
    wm[i] -= h;
    const double fdw = (objective(src0, tgt0, wp) - objective(src0, tgt0, wm)).item<double>() / (2 * h);
    EXPECT_NEAR(w.grad()[i].item<double>(), fdw, 1e-5 * (1.0 + std::abs(fdw)));
  }
}

TEST_F(WeightedProcrustesTest, RejectsShapeMismatch) {
  EXPECT_THROW(WeightedProcrustes(torch::zeros({5, 3}), torch::zeros({4, 3}), torch::ones({5})), c10::Error);
  EXPECT_THROW(WeightedProcrustes(torch::zeros({5, 3}), torch::zeros({5, 3}), torch::ones({4})), c10::Error);
}

}  // namespace
}  // namespace nerfreg
