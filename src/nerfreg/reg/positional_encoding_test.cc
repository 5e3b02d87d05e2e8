#include "nerfreg/reg/positional_encoding.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nerfreg {
namespace {

TEST(PositionalEncodingTest, PaperShapeLayoutAndPadding) {
  PositionalEncodingOptions o;  // d 256 -> 84 per axis + 4 zero columns
  EXPECT_EQ(o.FeaturesPerAxis(), 84);
  const torch::Tensor xyz = torch::randn({5, 3});
  const torch::Tensor pe = SinePositionalEncoding(xyz, o);
  ASSERT_EQ(pe.sizes(), torch::IntArrayRef({5, 256}));
  EXPECT_EQ(pe.slice(1, 252).abs().max().item<float>(), 0.0f);
  // Each axis block depends on its own coordinate only.
  torch::Tensor moved = xyz.clone();
  moved.select(1, 1) += 0.3;
  const torch::Tensor pe2 = SinePositionalEncoding(moved, o);
  EXPECT_TRUE(torch::equal(pe.slice(1, 0, 84), pe2.slice(1, 0, 84)));
  EXPECT_GT((pe.slice(1, 84, 168) - pe2.slice(1, 84, 168)).abs().max().item<float>(), 0.1f);
  EXPECT_TRUE(torch::equal(pe.slice(1, 168, 252), pe2.slice(1, 168, 252)));
}

TEST(PositionalEncodingTest, ValuesAtKnownPoints) {
  PositionalEncodingOptions o;
  o.d_model = 12;  // 4 per axis: sin f0, cos f0, sin f1, cos f1, f1 = 1 / T^(2/4)
  const torch::Tensor xyz = torch::tensor({{0.0, 0.25, -0.5}}, torch::kDouble);
  const torch::Tensor pe = SinePositionalEncoding(xyz, o)[0];
  ASSERT_EQ(pe.size(0), 12);
  const double f1 = 1.0 / std::pow(1000.0, 0.5);
  const double expected[12] = {0.0,
                               1.0,
                               0.0,
                               1.0,  // x = 0
                               std::sin(0.5 * M_PI),
                               std::cos(0.5 * M_PI),
                               std::sin(0.5 * M_PI * f1),
                               std::cos(0.5 * M_PI * f1),  // y = 0.25: arg 2 pi * 0.25
                               std::sin(-M_PI),
                               std::cos(-M_PI),
                               std::sin(-M_PI * f1),
                               std::cos(-M_PI * f1)};
  for (int i = 0; i < 12; ++i) EXPECT_NEAR(pe[i].item<double>(), expected[i], 1e-12) << "column " << i;
}

TEST(PositionalEncodingTest, RejectsBadInput) {
  PositionalEncodingOptions o;
  EXPECT_THROW(SinePositionalEncoding(torch::zeros({4, 2}), o), c10::Error);
  o.d_model = 4;
  EXPECT_FALSE(o.Check());
}

}  // namespace
}  // namespace nerfreg
