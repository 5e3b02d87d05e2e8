#include "nerfreg/reg/backbone.h"

#include <gtest/gtest.h>


namespace nerfreg {
namespace {

TEST(Backbone, CpuConfigForwardBackwardShapesAndFiniteGradients) {
  torch::set_num_threads(2);
  torch::manual_seed(1);
  Backbone net(BackboneOptions::Cpu());
  const torch::Tensor grid = torch::rand({1, 4, 32, 32, 32});
  const torch::Tensor mask = torch::rand({32, 32, 32}) > 0.9;
  // Speed is measured in bench/, not here.
  const torch::Tensor f = net->ForwardAtMask(grid, mask);
  ASSERT_EQ(f.size(0), mask.sum().item<int64_t>());
  ASSERT_EQ(f.size(1), 32);
  f.pow(2).mean().backward();
  int64_t with_grad = 0;
  for (const auto& p : net->parameters()) {
    ASSERT_TRUE(p.grad().defined());
    EXPECT_TRUE(torch::isfinite(p.grad()).all().item<bool>());
    with_grad += p.grad().abs().sum().item<double>() > 0;
  }
  EXPECT_GT(with_grad, static_cast<int64_t>(net->parameters().size()) / 2);
}

TEST(Backbone, PaperConfigHasResNet50Layout) {
  const auto o = BackboneOptions::Paper();
  EXPECT_EQ(o.stage_blocks, (std::vector<int64_t>{3, 4, 6, 3}));
  EXPECT_EQ(o.stage_widths.back() * 4, 2048);
  EXPECT_EQ(o.fpn_channels, 256);
}

TEST(Backbone, RejectsBadGrid) {
  Backbone net(BackboneOptions::Cpu());
  EXPECT_THROW(net->forward(torch::rand({1, 3, 32, 32, 32})), c10::Error);
  EXPECT_THROW(net->forward(torch::rand({1, 4, 30, 32, 32})), c10::Error);
}

}  // namespace
}  // namespace nerfreg
