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

// The features of a grid must not depend on the module's mode, nor on the grids seen before it:
// training runs one grid per pass, so inference has to normalise the way training did (a
// BatchNorm at inference used running averages that fit no single grid; backbone.cc, Norm).
TEST(Backbone, FeaturesOfAGridAreTheSameInTrainingAndInference) {
  torch::set_num_threads(2);
  torch::manual_seed(2);
  Backbone net(BackboneOptions::Cpu());
  const torch::Tensor sparse = torch::rand({1, 4, 32, 32, 32}) * (torch::rand({1, 1, 32, 32, 32}) > 0.95);
  const torch::Tensor dense = 0.5 + 0.5 * torch::rand({1, 4, 32, 32, 32});
  torch::optim::SGD sgd(net->parameters(), 0.1);
  for (int step = 0; step < 3; ++step) {  // move the scales and shifts off their initial values
    sgd.zero_grad();
    (net->forward(dense).mean() - net->forward(sparse).pow(2).mean()).backward();
    sgd.step();
  }
  torch::NoGradGuard no_grad;
  net->train();
  const torch::Tensor train_sparse = net->forward(sparse);
  net->forward(dense);
  net->eval();
  const torch::Tensor eval_sparse = net->forward(sparse);
  EXPECT_TRUE(torch::allclose(train_sparse, eval_sparse, 1e-4, 1e-5))
      << "max difference " << (train_sparse - eval_sparse).abs().max().item<float>();
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
