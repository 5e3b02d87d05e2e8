#include "nerfreg/util/image_metrics.h"

#include <gtest/gtest.h>

#include <random>

namespace nerfreg {
namespace {

TEST(ImageMetrics, PsnrAndSsimBehave) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0, 1);
  Image a(32, 24, 3);
  for (auto& v : a.data) v = u(rng);
  Image b = a;
  EXPECT_NEAR(Ssim(a, b), 1.0, 1e-9);
  for (auto& v : b.data) v = std::min(1.f, v + 0.1f);
  EXPECT_NEAR(Psnr(a, Image(a)), 100.0, 1e-9);
  Image c = a;
  for (auto& v : c.data) v += 0.1f;  // MSE 0.01 -> 20 dB
  EXPECT_NEAR(Psnr(a, c), 20.0, 1e-4);
  Image noisy = a;
  for (auto& v : noisy.data) v = 0.5f * v + 0.5f * u(rng);
  EXPECT_LT(Ssim(a, noisy), Ssim(a, b));
  EXPECT_THROW(Psnr(a, Image(8, 8, 3)), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
