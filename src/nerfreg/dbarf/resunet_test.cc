#include "nerfreg/dbarf/resunet.h"

#include <gtest/gtest.h>

namespace nerfreg {
namespace {

TEST(ResUNet, CpuConfigShapesAndFiniteGradients) {
  torch::manual_seed(3);
  ResUNet net(ResUNetOptions::Cpu());
  const torch::Tensor images = torch::rand({2, 3, 24, 32});
  const torch::Tensor f = net->forward(images);
  ASSERT_EQ(f.sizes(), torch::IntArrayRef({2, 32, 6, 8}));
  // An odd size: 1/4 rounds up, as strided convs do.
  EXPECT_EQ(net->forward(torch::rand({1, 3, 30, 18})).sizes(), torch::IntArrayRef({1, 32, 8, 5}));
  const torch::Tensor nerf = net->NerfFeatures(images);
  ASSERT_EQ(nerf.size(1), 16);
  EXPECT_TRUE(torch::equal(nerf, f.narrow(1, 0, 16)));
  nerf.pow(2).mean().backward();
  int64_t with_grad = 0;
  for (const auto& p : net->parameters()) {
    ASSERT_TRUE(p.grad().defined());
    EXPECT_TRUE(torch::isfinite(p.grad()).all().item<bool>());
    with_grad += p.grad().abs().sum().item<double>() > 0;
  }
  EXPECT_GT(with_grad, static_cast<int64_t>(net->parameters().size()) / 2);
}

TEST(ResUNet, ViewsAreIndependent) {
  // InstanceNorm: a view's features do not depend on the other views in the batch.
  torch::manual_seed(4);
  ResUNet net(ResUNetOptions::Cpu());
  const torch::Tensor a = torch::rand({1, 3, 24, 24}), b = torch::rand({1, 3, 24, 24});
  const torch::Tensor both = net->forward(torch::cat({a, b}));
  EXPECT_LT((both[0] - net->forward(a)[0]).abs().max().item<double>(), 1e-5);
}

TEST(ResUNet, PaperConfigLayoutAndOutput) {
  const auto o = ResUNetOptions::Paper();
  EXPECT_EQ(o.layer_blocks, (std::vector<int64_t>{3, 4, 6}));
  EXPECT_EQ(o.layer_channels, (std::vector<int64_t>{64, 128, 256}));
  EXPECT_EQ(o.out_channels, 64);
  EXPECT_EQ(o.nerf_channels, 32);
  torch::NoGradGuard no_grad;
  ResUNet net(o);
  EXPECT_EQ(net->forward(torch::rand({1, 3, 32, 48})).sizes(), torch::IntArrayRef({1, 64, 8, 12}));
}

TEST(ResUNet, RejectsBadOptionsAndInputs) {
  ResUNetOptions o = ResUNetOptions::Cpu();
  o.nerf_channels = o.out_channels + 1;
  EXPECT_FALSE(o.Check());
  o = ResUNetOptions::Cpu();
  o.layer_blocks = {1, 1};
  EXPECT_FALSE(o.Check());
  ResUNet net(ResUNetOptions::Cpu());
  EXPECT_THROW(net->forward(torch::rand({1, 4, 16, 16})), c10::Error);
  EXPECT_THROW(net->forward(torch::rand({1, 3, 8, 16})), c10::Error);
}

}  // namespace
}  // namespace nerfreg
