#include "nerfreg/dbarf/pose_depth_net.h"

#include <gtest/gtest.h>

#include <map>
#include <string>

#include "nerfreg/dbarf/inverse_warp.h"
#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/sfm_loss.h"
#include "nerfreg/dbarf/test_scene.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

using testing_scene::PlaneScene;

class PoseDepthNetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(2);
    torch::manual_seed(17);
  }
};

// Features as a fixed function of the image: colour, squared colour and a blurred copy.
torch::Tensor ImageFeatures(const torch::Tensor& image) {
  namespace F = torch::nn::functional;
  const torch::Tensor blur = F::avg_pool2d(F::pad(image, F::PadFuncOptions({1, 1, 1, 1}).mode(torch::kReplicate)),
                                           F::AvgPool2dFuncOptions(3).stride(1));
  return torch::cat({image, image * image, blur}, 1);
}

TEST_F(PoseDepthNetTest, CostMapIsZeroAtTheTruePoseAndDepthAndGrowsWhenPerturbed) {
  const PlaneScene scene = PlaneScene::Tilted(2.0);
  const torch::Tensor src_from_tgt = testing_scene::SourcePoses(3);
  std::vector<torch::Tensor> sources;
  for (int64_t i = 0; i < 3; ++i) sources.push_back(ImageFeatures(scene.Render(src_from_tgt[i])));
  const torch::Tensor f_src = torch::cat(sources, 0);
  const torch::Tensor f_tgt = ImageFeatures(scene.Render(torch::eye(4)));
  const torch::Tensor inv_depth = scene.TargetInverseDepth();
  const torch::Tensor valid = InverseWarp(f_src, inv_depth, src_from_tgt, scene.intrinsics).valid;
  const auto mean_cost = [&](const torch::Tensor& poses, const torch::Tensor& inv) {
    const torch::Tensor cost = FeatureCostMaps(f_tgt, f_src, inv, poses, scene.intrinsics);
    EXPECT_EQ(cost.sizes(), f_src.sizes());
    return ((cost * valid).sum() / (valid.sum() * cost.size(1))).item<double>();
  };
  const double at_truth = mean_cost(src_from_tgt, inv_depth);
  const torch::Tensor delta = torch::tensor({0.0, 0.0, 0.0, 0.0, 0.03, 0.0}, torch::kFloat).expand({3, 6});
  const double rotated = mean_cost(Se3Update(delta, src_from_tgt), inv_depth);
  const double deeper = mean_cost(src_from_tgt, 0.7 * inv_depth);
  EXPECT_LT(at_truth, 2e-5);
  EXPECT_GT(rotated, 50.0 * at_truth);
  EXPECT_GT(deeper, 20.0 * at_truth);
  EXPECT_GT(rotated, 1e-3);
}

TEST_F(PoseDepthNetTest, CostMapAtEighthResolutionUsesScaledIntrinsics) {
  // Features that are a smooth function of the plane point are consistent at any resolution: the
  // cost at 1/8 with K/8 (focal and principal point) is near zero, with K unscaled it is not.
  const PlaneScene full = PlaneScene::FrontoParallel(2.0, 192, 256);
  PlaneScene low = full;
  low.height = 24;
  low.width = 32;
  low.intrinsics = ScaleIntrinsics(full.intrinsics, 1.0 / 8.0);
  const torch::Tensor src_from_tgt = testing_scene::SourcePoses(2);
  const torch::Tensor f_src = torch::cat({low.Render(src_from_tgt[0]), low.Render(src_from_tgt[1])}, 0);
  const torch::Tensor f_tgt = low.Render(torch::eye(4));
  const torch::Tensor inv = low.TargetInverseDepth();
  const torch::Tensor valid = InverseWarp(f_src, inv, src_from_tgt, low.intrinsics).valid;
  const auto cost = [&](const torch::Tensor& k) {
    return ((FeatureCostMaps(f_tgt, f_src, inv, src_from_tgt, k) * valid).sum() / (3 * valid.sum())).item<double>();
  };
  torch::Tensor k_focal_only = low.intrinsics.clone();
  k_focal_only[0][2] = full.intrinsics[0][2];  // the original's bug: cx, cy left unscaled
  k_focal_only[1][2] = full.intrinsics[1][2];
  EXPECT_LT(cost(low.intrinsics), 1e-3);
  EXPECT_GT(cost(k_focal_only), 5.0 * cost(low.intrinsics));
}

TEST_F(PoseDepthNetTest, ConvexUpsampleWithACentredMaskRepeatsPixels) {
  const torch::Tensor x = torch::rand({2, 1, 3, 4});
  torch::Tensor mask = torch::zeros({2, 9, 4, 4, 3, 4});
  mask.select(1, 4).fill_(50.0);  // all weight on the centre of the 3x3 neighbourhood
  const torch::Tensor up = ConvexUpsample(x, mask.view({2, 9 * 16, 3, 4}), 4);
  ASSERT_EQ(up.sizes(), (std::vector<int64_t>{2, 1, 12, 16}));
  const torch::Tensor nearest = x.repeat_interleave(4, 2).repeat_interleave(4, 3);
  EXPECT_LT((up - nearest).abs().max().item<double>(), 1e-5);
  // Uniform weights average the neighbourhood (interior pixel).
  const torch::Tensor avg = ConvexUpsample(x, torch::zeros({2, 9 * 16, 3, 4}), 4);
  EXPECT_NEAR(avg[0][0][5][5].item<double>(), x[0][0].slice(0, 0, 3).slice(1, 0, 3).mean().item<double>(), 1e-5);
}

TEST_F(PoseDepthNetTest, OptionsCheck) {
  EXPECT_TRUE(PoseDepthNetOptions::Paper().Check());
  EXPECT_TRUE(PoseDepthNetOptions::Cpu().Check());
  auto o = PoseDepthNetOptions::Cpu();
  o.near = 5.0;
  o.far = 1.0;
  EXPECT_FALSE(o.Check());
  o = PoseDepthNetOptions::Cpu();
  o.encoder_widths = {8, 16};
  EXPECT_FALSE(o.Check());
  o = PoseDepthNetOptions::Cpu();
  o.inner_iterations = 0;
  EXPECT_FALSE(o.Check());
  EXPECT_THROW(PoseDepthNet{o}, c10::Error);
}

TEST_F(PoseDepthNetTest, ForwardShapesRangesAndFiniteGradients) {
  const auto options = PoseDepthNetOptions::Cpu();
  PoseDepthNet net(options);
  // The pose heads' last layers start at zero (an untrained network returns its initial poses);
  // give them small values so that gradients reach the layers before them too.
  {
    torch::NoGradGuard no_grad;
    int zeroed = 0;
    for (auto& p : net->named_parameters()) {
      if (p.key().find("pose_head.2.") == std::string::npos && p.key().find("pose_delta_head.2.") == std::string::npos)
        continue;
      EXPECT_EQ(p.value().abs().max().item<double>(), 0.0) << p.key();
      p.value().normal_(0.0, 0.01);
      ++zeroed;
    }
    EXPECT_EQ(zeroed, 4);  // weight and bias of both heads
  }
  const PlaneScene scene = PlaneScene::Tilted(2.0, 48, 64);
  const torch::Tensor poses = testing_scene::SourcePoses(2);
  const torch::Tensor target = scene.Render(torch::eye(4));
  const torch::Tensor sources = torch::cat({scene.Render(poses[0]), scene.Render(poses[1])}, 0);
  const auto pred = net->forward(target, sources, scene.intrinsics);
  ASSERT_EQ(pred.inv_depths.size(), 3u);  // initial + 2 outer iterations
  ASSERT_EQ(pred.src_from_tgt.size(), 3u);
  EXPECT_EQ(pred.target_features.sizes(), (std::vector<int64_t>{1, options.feature_channels, 6, 8}));
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(pred.inv_depths[k].sizes(), (std::vector<int64_t>{1, 1, 48, 64}));
    EXPECT_GE(pred.inv_depths[k].min().item<double>(), 1.0 / options.far - 1e-6);
    EXPECT_LE(pred.inv_depths[k].max().item<double>(), 1.0 / options.near + 1e-5);
    EXPECT_EQ(pred.src_from_tgt[k].sizes(), (std::vector<int64_t>{2, 4, 4}));
    const torch::Tensor r = pred.src_from_tgt[k].slice(1, 0, 3).slice(2, 0, 3);
    EXPECT_LT((torch::matmul(r.transpose(1, 2), r) - torch::eye(3)).abs().max().item<double>(), 1e-4);
  }
  // Without auto-masking every warped pixel counts, so the pose path receives gradients even from
  // an untrained network (whose warps the un-warped sources would otherwise beat everywhere).
  SfmLossOptions loss_options;
  loss_options.auto_mask = false;
  const auto loss = SfmLoss(target, sources, pred.inv_depths, pred.src_from_tgt, scene.intrinsics, loss_options);
  ASSERT_TRUE(std::isfinite(loss.total.item<double>()));
  loss.total.backward();
  int64_t with_grad = 0, total = 0;
  for (const auto& p : net->named_parameters()) {
    ++total;
    if (!p.value().grad().defined()) continue;
    EXPECT_TRUE(torch::isfinite(p.value().grad()).all().item<bool>()) << p.key();
    if (p.value().grad().abs().sum().item<double>() > 0) ++with_grad;
  }
  // Every part reaches the loss (encoders, heads, GRUs, motion encoders, mask heads).
  EXPECT_EQ(with_grad, total);
}

// A depth pushed past the far bound shows the far bound, yet a loss on it still reaches the depth
// updates: with a plain clamp their gradient is zero there, and a depth that has collapsed to the
// far bound during training never comes back (what happened training from the identity).
TEST_F(PoseDepthNetTest, ADepthClampedAtTheFarBoundStillReceivesGradients) {
  const auto options = PoseDepthNetOptions::Cpu();
  PoseDepthNet net(options);
  torch::Tensor bias;
  {
    torch::NoGradGuard no_grad;
    for (auto& p : net->named_parameters()) {
      if (p.key() == "depth_delta_head.2.bias") bias = p.value();
    }
    ASSERT_TRUE(bias.defined());
    bias.fill_(-2.0);  // every update is about tanh(-2) = -0.96: below the range after one step
  }
  const PlaneScene scene = PlaneScene::Tilted(2.0, 48, 64);
  const torch::Tensor poses = testing_scene::SourcePoses(2);
  const torch::Tensor target = scene.Render(torch::eye(4));
  const torch::Tensor sources = torch::cat({scene.Render(poses[0]), scene.Render(poses[1])}, 0);
  const auto pred = net->forward(target, sources, scene.intrinsics);
  const torch::Tensor last = pred.inv_depths.back();  // [1, 1, 48, 64]
  EXPECT_NEAR(last.max().item<double>(), 1.0 / options.far, 1e-6);
  EXPECT_NEAR(last.min().item<double>(), 1.0 / options.far, 1e-6);
  last.mean().backward();  // a loss that wants the depth nearer
  ASSERT_TRUE(bias.grad().defined());
  EXPECT_GT(bias.grad().abs().sum().item<double>(), 0.0);
}

TEST_F(PoseDepthNetTest, SetRotationScaleKeepsTheFunction) {
  PoseDepthNetOptions o = PoseDepthNetOptions::Cpu();
  o.outer_iterations = 1;
  o.inner_iterations = 1;
  PoseDepthNet net(o);
  // Non-zero pose heads (they start at zero), so the rotation rows matter.
  {
    torch::NoGradGuard no_grad;
    for (auto& p : net->named_parameters()) {
      if (p.key().find("pose_head") != std::string::npos || p.key().find("pose_delta_head") != std::string::npos) {
        p.value().normal_(0.0, 0.05);
      }
    }
  }
  net->eval();
  const torch::Tensor target = torch::rand({1, 3, 32, 48}), sources = torch::rand({2, 3, 32, 48});
  const torch::Tensor k = torch::tensor({40.0, 0.0, 24.0, 0.0, 40.0, 16.0, 0.0, 0.0, 1.0}).view({3, 3});
  torch::NoGradGuard no_grad;
  const PoseDepthPrediction before = net->forward(target, sources, k);
  net->SetRotationScale(1.0);
  EXPECT_EQ(net->options().rotation_scale, 1.0);
  const PoseDepthPrediction after = net->forward(target, sources, k);
  EXPECT_GT(Se3Log(before.src_from_tgt.back()).slice(1, 3, 6).abs().max().item<double>(), 1e-5);
  for (size_t i = 0; i < before.src_from_tgt.size(); ++i) {
    EXPECT_TRUE(torch::allclose(before.src_from_tgt[i], after.src_from_tgt[i], 1e-4, 1e-5)) << i;
  }
  EXPECT_THROW(net->SetRotationScale(0.0), c10::Error);
}

TEST_F(PoseDepthNetTest, ReinitialiseHeadsKeepsTheEncodersAndReturnsTheInitialPosesAgain) {
  PoseDepthNetOptions o = PoseDepthNetOptions::Cpu();
  PoseDepthNet net(o);
  // A trained network stands in: every parameter moved off its initial value.
  {
    torch::NoGradGuard no_grad;
    for (auto& p : net->parameters()) p.add_(torch::randn_like(p) * 0.05);
  }
  std::map<std::string, torch::Tensor> before;
  for (const auto& p : net->named_parameters()) before[p.key()] = p.value().clone();
  net->eval();
  const torch::Tensor target = torch::rand({1, 3, 32, 48}), sources = torch::rand({2, 3, 32, 48});
  const torch::Tensor k = torch::tensor({40.0, 0.0, 24.0, 0.0, 40.0, 16.0, 0.0, 0.0, 1.0}).view({3, 3});
  torch::NoGradGuard no_grad;
  // With the perturbed heads the network moves the cameras.
  EXPECT_GT(Se3Log(net->forward(target, sources, k).src_from_tgt.back()).abs().max().item<double>(), 1e-3);

  net->ReinitialiseHeads();
  int encoders = 0, redrawn = 0;
  for (const auto& p : net->named_parameters()) {
    const bool encoder = p.key().rfind("fnet.", 0) == 0 || p.key().rfind("cnet_", 0) == 0;
    const bool same = torch::equal(p.value(), before[p.key()]);
    if (encoder) {
      EXPECT_TRUE(same) << p.key();
      ++encoders;
    } else {
      EXPECT_FALSE(same) << p.key();
      ++redrawn;
    }
  }
  EXPECT_GT(encoders, 0);
  EXPECT_GT(redrawn, 0);
  // From the identity it returns the identity at every prediction, and given poses unchanged.
  const PoseDepthPrediction from_identity = net->forward(target, sources, k);
  for (const auto& poses : from_identity.src_from_tgt) {
    EXPECT_TRUE(torch::allclose(poses, torch::eye(4).expand({2, 4, 4}), 0.0, 1e-6));
  }
  const torch::Tensor given =
      Se3Exp(torch::tensor({{0.1, 0.0, 0.0, 0.0, 0.02, 0.0}, {0.0, -0.1, 0.0, 0.01, 0.0, 0.0}}).to(torch::kFloat));
  const PoseDepthPrediction from_given = net->forward(target, sources, k, given);
  EXPECT_TRUE(torch::allclose(from_given.src_from_tgt.back(), given, 0.0, 1e-6));
  // The depth heads were redrawn too: the prediction stays in range and finite.
  EXPECT_TRUE(torch::isfinite(from_identity.inv_depths.back()).all().item<bool>());
}

TEST_F(PoseDepthNetTest, PaperConfigurationRunsOnASmallImage) {
  torch::NoGradGuard no_grad;
  PoseDepthNet net(PoseDepthNetOptions::Paper());
  const torch::Tensor k = torch::tensor({{40.0f, 0.0f, 32.0f}, {0.0f, 40.0f, 24.0f}, {0.0f, 0.0f, 1.0f}});
  const auto pred = net->forward(torch::rand({1, 3, 50, 64}), torch::rand({3, 3, 50, 64}), k);
  ASSERT_EQ(pred.inv_depths.size(), 4u);
  EXPECT_EQ(pred.inv_depths.back().sizes(), (std::vector<int64_t>{1, 1, 50, 64}));
  EXPECT_EQ(pred.src_from_tgt.back().sizes(), (std::vector<int64_t>{3, 4, 4}));
  EXPECT_EQ(pred.target_features.size(1), 128);
  EXPECT_TRUE(torch::isfinite(pred.inv_depths.back()).all().item<bool>());
}

TEST_F(PoseDepthNetTest, TrainingOnOneSyntheticPairLowersTheSfmLoss) {
  auto options = PoseDepthNetOptions::Cpu();
  options.near = 0.5;
  options.far = 20.0;
  PoseDepthNet net(options);
  const PlaneScene scene = PlaneScene::Tilted(2.0, 48, 64);
  const torch::Tensor poses = testing_scene::SourcePoses(2);
  const torch::Tensor target = scene.Render(torch::eye(4));
  const torch::Tensor sources = torch::cat({scene.Render(poses[0]), scene.Render(poses[1])}, 0);
  torch::optim::Adam adam(net->parameters(), torch::optim::AdamOptions(1e-3));
  double first = 0, last = 0;
  const int steps = 25;
  for (int step = 0; step < steps; ++step) {
    adam.zero_grad();
    const auto pred = net->forward(target, sources, scene.intrinsics);
    const auto loss = SfmLoss(target, sources, pred.inv_depths, pred.src_from_tgt, scene.intrinsics);
    loss.total.backward();
    adam.step();
    const double final_photometric = loss.photometric[loss.photometric.size(0) - 1].item<double>();
    if (step == 0) first = final_photometric;
    if (step >= steps - 5) last += final_photometric / 5.0;
  }
  LOG_INFO("network training: final-prediction photometric loss {:.4f} -> {:.4f}", first, last);
  EXPECT_LT(last, 0.6 * first);
}

}  // namespace
}  // namespace nerfreg
