#include "nerfreg/dbarf/sfm_loss.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/test_scene.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

using testing_scene::PlaneScene;

class SfmLossTest : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(1);
    torch::manual_seed(11);
    scene_ = PlaneScene::Tilted(2.0);
    src_from_tgt_ = testing_scene::SourcePoses(2);
    target_ = scene_.Render(torch::eye(4));
    sources_ = torch::cat({scene_.Render(src_from_tgt_[0]), scene_.Render(src_from_tgt_[1])}, 0);
    inv_depth_ = scene_.TargetInverseDepth();
  }
  PlaneScene scene_;
  torch::Tensor src_from_tgt_, target_, sources_, inv_depth_;
};

TEST_F(SfmLossTest, SsimAndErrorMapBehave) {
  const torch::Tensor x = torch::rand({2, 3, 16, 20});
  EXPECT_LT((Ssim(x, x) - 1.0).abs().max().item<double>(), 1e-5);
  EXPECT_LT(PhotometricErrorMap(x, x).abs().max().item<double>(), 1e-5);
  const torch::Tensor small = PhotometricErrorMap(x + 0.02 * torch::randn_like(x), x);
  const torch::Tensor large = PhotometricErrorMap(x + 0.2 * torch::randn_like(x), x);
  EXPECT_EQ(small.sizes(), (std::vector<int64_t>{2, 1, 16, 20}));
  EXPECT_GT(large.mean().item<double>(), 2.0 * small.mean().item<double>());
  // Pure L1 when ssim_weight = 0.
  const torch::Tensor y = x + 0.1;
  EXPECT_NEAR(PhotometricErrorMap(y, x, 0.0).mean().item<double>(), 0.1, 1e-5);
}

TEST_F(SfmLossTest, ClippingCapsEachMapAtMeanPlusHalfStd) {
  const torch::Tensor e = torch::rand({3, 1, 8, 8});
  const torch::Tensor c = ClipErrorMaps(e, 0.5);
  for (int64_t b = 0; b < 3; ++b) {
    const double limit = (e[b].mean() + 0.5 * e[b].std()).item<double>();
    EXPECT_NEAR(c[b].max().item<double>(), limit, 1e-6);
  }
  EXPECT_TRUE(torch::equal(ClipErrorMaps(e, -1.0), e));
}

TEST_F(SfmLossTest, SmoothnessIsZeroForConstantDepthAndScaleInvariant) {
  const torch::Tensor image = torch::rand({1, 3, 12, 12});
  EXPECT_NEAR(EdgeAwareSmoothness(torch::full({1, 1, 12, 12}, 0.3f), image).item<double>(), 0.0, 1e-7);
  const torch::Tensor d = torch::rand({1, 1, 12, 12}) + 0.1;
  EXPECT_GT(EdgeAwareSmoothness(d, image).item<double>(), 0.05);
  EXPECT_NEAR(EdgeAwareSmoothness(d, image).item<double>(), EdgeAwareSmoothness(5.0 * d, image).item<double>(), 1e-5);
  // Depth edges where the image has edges cost less than where it is flat.
  torch::Tensor step = torch::full({1, 1, 12, 12}, 0.5f);
  step.slice(3, 6, 12) = 1.0f;
  torch::Tensor edge_image = torch::zeros({1, 3, 12, 12});
  edge_image.slice(3, 6, 12) = 1.0f;
  EXPECT_LT(EdgeAwareSmoothness(step, edge_image).item<double>(),
            0.5 * EdgeAwareSmoothness(step, torch::zeros({1, 3, 12, 12})).item<double>());
}

TEST_F(SfmLossTest, LowerAtTheTruePoseAndDepthThanAtPerturbedOnes) {
  const SfmLossOptions options;
  const double at_truth =
      PhotometricLoss(target_, sources_, inv_depth_, src_from_tgt_, scene_.intrinsics, options).loss.item<double>();
  const torch::Tensor rot =
      torch::tensor({{0.0, 0.0, 0.0, 0.0, 0.03, 0.0}, {0.0, 0.0, 0.0, 0.02, 0.0, 0.01}}, torch::kFloat);
  const torch::Tensor trans =
      torch::tensor({{0.08, 0.0, 0.0, 0.0, 0.0, 0.0}, {0.0, -0.08, 0.0, 0.0, 0.0, 0.0}}, torch::kFloat);
  const double at_rot =
      PhotometricLoss(target_, sources_, inv_depth_, Se3Update(rot, src_from_tgt_), scene_.intrinsics, options)
          .loss.item<double>();
  const double at_trans =
      PhotometricLoss(target_, sources_, inv_depth_, Se3Update(trans, src_from_tgt_), scene_.intrinsics, options)
          .loss.item<double>();
  const double at_depth =
      PhotometricLoss(target_, sources_, 1.4 * inv_depth_, src_from_tgt_, scene_.intrinsics, options)
          .loss.item<double>();
  EXPECT_LT(at_truth, 0.01);
  EXPECT_GT(at_rot, 3.0 * at_truth);
  EXPECT_GT(at_trans, 3.0 * at_truth);
  EXPECT_GT(at_depth, 3.0 * at_truth);

  // The full loss over K = 2 predictions is the documented weighted sum.
  const auto full = SfmLoss(target_, sources_, {1.4 * inv_depth_, inv_depth_},
                            {Se3Update(rot, src_from_tgt_), src_from_tgt_}, scene_.intrinsics, options);
  const double first =
      PhotometricLoss(target_, sources_, 1.4 * inv_depth_, Se3Update(rot, src_from_tgt_), scene_.intrinsics, options)
          .loss.item<double>();
  EXPECT_NEAR(full.photometric[0].item<double>(), first, 1e-6);
  const double expected = 0.85 * first + 1.0 * at_truth + 0.01 * full.smoothness[0].item<double>() +
                          0.005 * full.smoothness[1].item<double>();
  EXPECT_NEAR(full.total.item<double>(), expected, 1e-6);
  EXPECT_NEAR(full.photometric[1].item<double>(), at_truth, 1e-6);
  EXPECT_GT(full.photometric[0].item<double>(), full.photometric[1].item<double>());
}

TEST_F(SfmLossTest, PyramidLevelsAddThePhotometricTermOfTheAveragedImages) {
  namespace F = torch::nn::functional;
  SfmLossOptions options;
  options.pyramid_levels = 3;
  const torch::Tensor rot =
      torch::tensor({{0.0, 0.0, 0.0, 0.0, 0.03, 0.0}, {0.0, 0.0, 0.0, 0.02, 0.0, 0.01}}, torch::kFloat);
  const torch::Tensor poses = Se3Update(rot, src_from_tgt_);
  const auto full = SfmLoss(target_, sources_, {inv_depth_}, {poses}, scene_.intrinsics, options);
  double expected = 0.01 * full.smoothness[0].item<double>();
  for (int64_t f : {1, 2, 4}) {
    const auto pool = [&](const torch::Tensor& x) {
      return f == 1 ? x : F::avg_pool2d(x, F::AvgPool2dFuncOptions(f).stride(f));
    };
    // Intrinsics for the pooled images: pixel centres at +0.5 make a plain scale exact.
    const torch::Tensor k = scene_.intrinsics * torch::tensor({1.0 / f, 1.0 / f, 1.0}, torch::kFloat).view({3, 1});
    const double level =
        PhotometricLoss(pool(target_), pool(sources_), pool(inv_depth_), poses, k, options).loss.item<double>();
    if (f == 1) EXPECT_NEAR(full.photometric[0].item<double>(), level, 1e-6);  // the record stays full-size
    expected += level;
  }
  EXPECT_NEAR(full.total.item<double>(), expected, 1e-6);
  // At the truth every level is small: the pooled warp is consistent.
  const auto truth = SfmLoss(target_, sources_, {inv_depth_}, {src_from_tgt_}, scene_.intrinsics, options);
  EXPECT_LT(truth.total.item<double>(), 0.25 * full.total.item<double>());

  options.pyramid_levels = 0;
  EXPECT_FALSE(options.Check());
  options.pyramid_levels = 7;
  EXPECT_FALSE(options.Check());
  options.pyramid_levels = 5;  // 48 px high: the coarsest level (1/16) would be 3 px
  EXPECT_THROW(SfmLoss(target_, sources_, {inv_depth_}, {poses}, scene_.intrinsics, options), c10::Error);
}

TEST_F(SfmLossTest, PhotometricLossGradientsMatchFiniteDifferences) {
  SfmLossOptions options;
  options.auto_mask = false;       // the per-pixel minimum and
  options.clip_std_factor = -1.0;  // the clipping are piecewise; test the smooth core
  const torch::Tensor tgt = target_.to(torch::kDouble), src = sources_.to(torch::kDouble);
  const torch::Tensor k = scene_.intrinsics.to(torch::kDouble);
  const torch::Tensor inv = inv_depth_.to(torch::kDouble);
  const torch::Tensor start = Se3Update(
      torch::tensor({{0.02, -0.01, 0.01, 0.01, -0.02, 0.01}, {-0.01, 0.02, 0.0, -0.01, 0.01, 0.02}}, torch::kDouble),
      src_from_tgt_.to(torch::kDouble));
  const auto loss_of = [&](const torch::Tensor& delta, const torch::Tensor& depth_scale) {
    return PhotometricLoss(tgt, src, inv * depth_scale, Se3Update(delta, start), k, options).loss;
  };
  const torch::Tensor delta = torch::zeros({2, 6}, torch::dtype(torch::kDouble).requires_grad(true));
  const torch::Tensor scale = torch::ones({}, torch::dtype(torch::kDouble).requires_grad(true));
  loss_of(delta, scale).backward();
  const double eps = 1e-7;
  torch::NoGradGuard no_grad;
  torch::Tensor fd = torch::zeros({2, 6}, torch::kDouble);
  for (int64_t i = 0; i < 2; ++i) {
    for (int64_t j = 0; j < 6; ++j) {
      torch::Tensor e = torch::zeros({2, 6}, torch::kDouble);
      e[i][j] = eps;
      fd[i][j] = (loss_of(e, scale) - loss_of(-e, scale)) / (2 * eps);
    }
  }
  const torch::Tensor grad = delta.grad();
  EXPECT_GT(grad.abs().max().item<double>(), 1e-3);
  EXPECT_LT((grad - fd).abs().max().item<double>(), 1e-3 * grad.abs().max().item<double>())
      << "autograd " << grad << " finite differences " << fd;
  const double fd_scale = ((loss_of(delta, scale + eps) - loss_of(delta, scale - eps)) / (2 * eps)).item<double>();
  EXPECT_NEAR(scale.grad().item<double>(), fd_scale, 1e-3 * std::abs(fd_scale) + 1e-9);
}

struct PoseRecovery {
  double rot0, rot1, trans0, trans1, loss0, loss1;
};

// Perturbs both relative poses by ~3 degrees and 6 cm, then optimises left deltas by Adam (learning
// rate 3e-3; with decay, 1e-3 and 3e-4 for the last half and quarter) on the photometric loss with
// the true depth.
PoseRecovery RecoverPoses(const PlaneScene& scene, int steps, const SfmLossOptions& options, bool decay) {
  const torch::Tensor truth = testing_scene::SourcePoses(2);
  const torch::Tensor target = scene.Render(torch::eye(4));
  const torch::Tensor sources = torch::cat({scene.Render(truth[0]), scene.Render(truth[1])}, 0);
  const torch::Tensor inv_depth = scene.TargetInverseDepth();
  const torch::Tensor perturb =
      torch::tensor({{0.04, -0.03, 0.02, 0.03, -0.035, 0.02}, {-0.03, 0.04, 0.03, -0.025, 0.03, 0.035}}, torch::kFloat);
  const torch::Tensor start = Se3Update(perturb, truth);
  const auto rot_error = [&](const torch::Tensor& est) {
    return So3GeodesicAngle(est, truth).max().item<double>() * 180.0 / M_PI;
  };
  const auto trans_error = [&](const torch::Tensor& est) {
    return (est.slice(1, 0, 3).select(2, 3) - truth.slice(1, 0, 3).select(2, 3)).norm(2, 1).max().item<double>();
  };
  PoseRecovery r{};
  r.rot0 = rot_error(start);
  r.trans0 = trans_error(start);
  torch::Tensor delta = torch::zeros({2, 6}, torch::requires_grad());
  torch::optim::Adam adam({delta}, torch::optim::AdamOptions(3e-3));
  const auto set_lr = [&](double lr) {
    static_cast<torch::optim::AdamOptions&>(adam.param_groups()[0].options()).lr(lr);
  };
  for (int step = 0; step < steps; ++step) {
    if (decay && step == steps / 2) set_lr(1e-3);
    if (decay && step == 3 * steps / 4) set_lr(3e-4);
    adam.zero_grad();
    const torch::Tensor loss =
        PhotometricLoss(target, sources, inv_depth, Se3Update(delta, start), scene.intrinsics, options).loss;
    loss.backward();
    adam.step();
    if (step == 0) r.loss0 = loss.item<double>();
    r.loss1 = loss.item<double>();
  }
  r.rot1 = rot_error(Se3Update(delta.detach(), start));
  r.trans1 = trans_error(Se3Update(delta.detach(), start));
  LOG_INFO("pose refinement: rotation {:.3f} -> {:.3f} deg, translation {:.4f} -> {:.4f}, loss {:.4f} -> {:.4f}",
           r.rot0, r.rot1, r.trans0, r.trans1, r.loss0, r.loss1);
  return r;
}

TEST_F(SfmLossTest, OptimisingAPoseDeltaByThePhotometricLossRecoversThePose) {
  // A single plane leaves a rotation/translation ambiguity (bas-relief): a residual remains.
  const PoseRecovery plane = RecoverPoses(scene_, 150, SfmLossOptions{}, /*decay=*/false);
  EXPECT_GT(plane.rot0, 2.5);
  EXPECT_LT(plane.rot1, 0.25 * plane.rot0);
  EXPECT_LT(plane.trans1, 0.35 * plane.trans0);
  EXPECT_LT(plane.loss1, 0.5 * plane.loss0);
  // Depth variation (a ridge) resolves it; for refinement (static scene, no outliers) clipping and
  // auto-masking only discard information (measured: 0.095 deg with them after 400 steps, 0.034
  // deg without).
  SfmLossOptions refine;
  refine.clip_std_factor = -1.0;
  refine.auto_mask = false;
  const PoseRecovery ridge = RecoverPoses(PlaneScene::Ridge(2.0), 300, refine, /*decay=*/true);
  EXPECT_LT(ridge.rot1, 0.05 * ridge.rot0);
  EXPECT_LT(ridge.trans1, 0.15 * ridge.trans0);
}

}  // namespace
}  // namespace nerfreg

namespace nerfreg {
namespace {

// The downstream use: refine perturbed relative poses and an unknown inverse-depth map together
// (a coarse log-inverse-depth grid, bilinearly upsampled), from a constant-depth start.
TEST_F(SfmLossTest, JointPoseAndDepthRefinementFromAConstantDepth) {
  namespace F = torch::nn::functional;
  const torch::Tensor perturb =
      torch::tensor({{0.03, -0.02, 0.01, 0.025, -0.03, 0.015}, {-0.02, 0.03, 0.02, -0.02, 0.025, 0.03}}, torch::kFloat);
  const torch::Tensor start = Se3Update(perturb, src_from_tgt_);
  const auto rot_error = [&](const torch::Tensor& est) {
    return So3GeodesicAngle(est, src_from_tgt_).max().item<double>() * 180.0 / M_PI;
  };
  torch::Tensor delta = torch::zeros({2, 6}, torch::requires_grad());
  torch::Tensor log_inv = torch::full({1, 1, 12, 16}, std::log(0.5), torch::requires_grad());
  torch::optim::Adam adam({delta, log_inv}, torch::optim::AdamOptions(5e-3));
  const auto inv_depth_of = [&]() {
    return F::interpolate(torch::exp(log_inv), F::InterpolateFuncOptions()
                                                   .size(std::vector<int64_t>{scene_.height, scene_.width})
                                                   .mode(torch::kBilinear)
                                                   .align_corners(false));
  };
  const auto depth_error = [&]() {
    // Relative inverse-depth error after the best scale (scale is a gauge of the problem).
    const torch::Tensor est = inv_depth_of().detach();
    const double s = (inv_depth_.sum() / est.sum()).item<double>();
    return ((s * est - inv_depth_).abs() / inv_depth_).mean().item<double>();
  };
  const double rot0 = rot_error(start), depth0 = depth_error();
  SfmLossOptions options;
  for (int step = 0; step < 200; ++step) {
    adam.zero_grad();
    const torch::Tensor inv = inv_depth_of();
    const torch::Tensor loss =
        PhotometricLoss(target_, sources_, inv, Se3Update(delta, start), scene_.intrinsics, options).loss +
        1e-3 * EdgeAwareSmoothness(inv, target_);
    loss.backward();
    adam.step();
  }
  const double rot1 = rot_error(Se3Update(delta.detach(), start)), depth1 = depth_error();
  LOG_INFO("joint refinement: rotation {:.3f} -> {:.3f} deg, inverse-depth error {:.3f} -> {:.3f}", rot0, rot1, depth0,
           depth1);
  EXPECT_LT(rot1, 0.5 * rot0);
  EXPECT_LT(depth1, 0.5 * depth0);
}

}  // namespace
}  // namespace nerfreg
