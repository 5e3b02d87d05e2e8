#include "nerfreg/render/blocks.h"

#include <gtest/gtest.h>

namespace nerfreg {
namespace {

TEST(Blocks, KMeansSeparatesTwoClustersDeterministically) {
  std::vector<Eigen::Vector3d> pts;
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 0.1);
  for (int i = 0; i < 40; ++i) {
    const double side = i % 2 ? 2.0 : -2.0;
    pts.push_back({side + g(rng), g(rng), g(rng)});
  }
  const auto a = KMeans(pts, 2, 5), b = KMeans(pts, 2, 5);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a[0], 0);
  for (int i = 0; i < 40; ++i) EXPECT_EQ(a[i], i % 2) << i;
  EXPECT_THROW(KMeans(pts, 0, 1), std::invalid_argument);
}

TEST(Blocks, RandomFramesRespectTheirBounds) {
  std::mt19937 rng(4);
  BlockFrameOptions capped;
  capped.max_rotation_deg = 30;
  capped.max_translation = 0.1;
  capped.min_scale = 0.5;
  capped.max_scale = 2.0;
  double unbounded_mean = 0;
  for (int i = 0; i < 200; ++i) {
    const Sim3d t = RandomBlockFrame(capped, rng);
    EXPECT_LE(RotationErrorDeg(t.rotation, Eigen::Quaterniond::Identity()), 30 + 1e-9);
    EXPECT_LE(t.translation.cwiseAbs().maxCoeff(), 0.1 + 1e-12);
    EXPECT_GE(t.scale, 0.5);
    EXPECT_LE(t.scale, 2.0);
    unbounded_mean +=
        RotationErrorDeg(RandomBlockFrame(BlockFrameOptions{}, rng).rotation, Eigen::Quaterniond::Identity());
  }
  // xi ~ N(0, I) rotation vectors: a mean angle around 90 degrees (spec: ~92).
  EXPECT_NEAR(unbounded_mean / 200, 90, 12);
}

}  // namespace
}  // namespace nerfreg
