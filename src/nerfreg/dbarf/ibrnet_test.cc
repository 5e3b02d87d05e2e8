#include "nerfreg/dbarf/ibrnet.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nerfreg {
namespace {

// Random but plausible IBRNet inputs: R rays, S samples, V views, C feature channels.
struct Inputs {
  torch::Tensor rgb_feat, ray_diff, mask;
};
Inputs RandomInputs(int64_t r, int64_t s, int64_t v, int64_t c) {
  Inputs in;
  in.rgb_feat = torch::rand({r, s, v, 3 + c});
  const torch::Tensor dir = torch::randn({r, s, v, 3});
  in.ray_diff = torch::cat({dir / dir.norm(2, -1, true), torch::rand({r, s, v, 1}) * 2 - 1}, -1);
  in.mask = torch::rand({r, s, v}) > 0.3;
  return in;
}

TEST(IbrNet, PositionalEncodingForAnySampleCount) {
  for (int64_t n : {1, 7, 64, 100}) {
    const torch::Tensor pe = SamplePositionalEncoding(n, 16);
    ASSERT_EQ(pe.sizes(), torch::IntArrayRef({n, 16}));
    for (int64_t i : {int64_t{0}, n - 1}) {
      for (int64_t j : {0, 1, 6, 15}) {
        const double angle = i / std::pow(10000.0, 2.0 * (j / 2) / 16.0);
        EXPECT_NEAR(pe[i][j].item<double>(), j % 2 == 0 ? std::sin(angle) : std::cos(angle), 1e-5);
      }
    }
  }
}

TEST(IbrNet, ForwardBackwardShapesAndFiniteGradients) {
  torch::manual_seed(5);
  IbrNet net(IbrNetOptions::Cpu());
  // 7 samples: any count works (the original hard-codes 64).
  Inputs in = RandomInputs(6, 7, 4, 16);
  in.rgb_feat.requires_grad_(true);
  const IbrNetOutput out = net->forward(in.rgb_feat, in.ray_diff, in.mask);
  ASSERT_EQ(out.rgb.sizes(), torch::IntArrayRef({6, 7, 3}));
  ASSERT_EQ(out.sigma.sizes(), torch::IntArrayRef({6, 7}));
  EXPECT_GE(out.sigma.min().item<double>(), 0.0);
  (out.rgb.sum() + out.sigma.sum()).backward();
  int64_t with_grad = 0;
  for (const auto& p : net->parameters()) {
    ASSERT_TRUE(p.grad().defined());
    EXPECT_TRUE(torch::isfinite(p.grad()).all().item<bool>());
    with_grad += p.grad().abs().sum().item<double>() > 0;
  }
  EXPECT_EQ(with_grad, static_cast<int64_t>(net->parameters().size()));
  EXPECT_TRUE(torch::isfinite(in.rgb_feat.grad()).all().item<bool>());
  EXPECT_EQ(net->s.item<float>(), 0.2f);
  // Paper configuration: 32 feature channels, 64 samples.
  IbrNet paper(IbrNetOptions::Paper());
  const Inputs p = RandomInputs(2, 64, 5, 32);
  EXPECT_EQ(paper->forward(p.rgb_feat, p.ray_diff, p.mask).rgb.sizes(), torch::IntArrayRef({2, 64, 3}));
}

TEST(IbrNet, PoolingWeightsSumToOneOverValidViews) {
  torch::manual_seed(6);
  IbrNet net(IbrNetOptions::Cpu());
  Inputs in = RandomInputs(5, 9, 6, 16);
  // At least two valid views per sample, so the weights cannot all tie with the minimum.
  in.mask.select(2, 0).fill_(true);
  in.mask.select(2, 1).fill_(true);
  const torch::Tensor w = net->PoolingWeights(in.ray_diff, in.mask).squeeze(-1);  // [R,S,V]
  EXPECT_LT((w.sum(2) - 1).abs().max().item<double>(), 1e-5);
  EXPECT_EQ(w.masked_select(~in.mask).abs().sum().item<double>(), 0.0);
  EXPECT_GE(w.min().item<double>(), 0.0);
  // Views seen at a larger angle (smaller dot product) weigh less.
  const torch::Tensor dot = in.ray_diff.select(3, 3);
  const torch::Tensor a = w.select(2, 0), b = w.select(2, 1);
  const torch::Tensor da = dot.select(2, 0), db = dot.select(2, 1);
  EXPECT_TRUE(((da > db) <= (a >= b)).all().item<bool>());
}

TEST(IbrNet, NoValidViewMeansZeroSigmaAndOneViewMeansItsColour) {
  torch::manual_seed(7);
  IbrNet net(IbrNetOptions::Cpu());
  Inputs in = RandomInputs(4, 8, 3, 16);
  in.mask.select(1, 2).fill_(false);  // sample 2 of every ray: no view
  in.mask.select(1, 5).fill_(false);  // sample 5: only view 1
  in.mask.select(1, 5).select(1, 1).fill_(true);
  const IbrNetOutput out = net->forward(in.rgb_feat, in.ray_diff, in.mask);
  EXPECT_EQ(out.sigma.select(1, 2).abs().max().item<double>(), 0.0);
  const torch::Tensor seen = in.rgb_feat.select(1, 5).select(1, 1).narrow(1, 0, 3);  // [R,3]
  EXPECT_LT((out.rgb.select(1, 5) - seen).abs().max().item<double>(), 1e-6);
  // Everywhere the colour is a convex blend of the views' colours.
  const torch::Tensor rgb = in.rgb_feat.narrow(3, 0, 3);
  EXPECT_TRUE((out.rgb <= std::get<0>(rgb.max(2)) + 1e-5).all().item<bool>());
  EXPECT_TRUE((out.rgb >= std::get<0>(rgb.min(2)) - 1e-5).all().item<bool>());
}

TEST(IbrNet, RejectsMismatchedInputs) {
  IbrNet net(IbrNetOptions::Cpu());
  const Inputs in = RandomInputs(2, 3, 4, 16);
  EXPECT_THROW(net->forward(in.rgb_feat.narrow(3, 0, 10), in.ray_diff, in.mask), c10::Error);
  EXPECT_THROW(net->forward(in.rgb_feat, in.ray_diff.narrow(2, 0, 3), in.mask), c10::Error);
  EXPECT_THROW(net->forward(in.rgb_feat, in.ray_diff, in.mask.to(torch::kFloat)), c10::Error);
  IbrNetOptions o;
  o.attention_heads = 3;
  EXPECT_FALSE(o.Check());
}

}  // namespace
}  // namespace nerfreg
