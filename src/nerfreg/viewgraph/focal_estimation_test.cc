#include "nerfreg/viewgraph/focal_estimation.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {
namespace {

Eigen::Matrix3d FundamentalOf(const Rigid3d& j_from_i, double focal, double cx, double cy) {
  Eigen::Matrix3d k;
  k << focal, 0, cx, 0, focal, cy, 0, 0, 1;
  const Eigen::Matrix3d e = Skew(j_from_i.translation) * j_from_i.RotationMatrix();
  return k.inverse().transpose() * e * k.inverse();
}

// Cameras at random places looking in random directions near +z (hand-held photos of a scene):
// their optical axes do not meet in one point.
std::vector<Rigid3d> HandHeldCameras(unsigned seed, int n, double spread_deg) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Rigid3d> cams;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d w = g(rng) * spread_deg * M_PI / 180 * Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Eigen::Quaterniond r(Eigen::AngleAxisd(w.norm(), w.normalized()));
    const Eigen::Vector3d center(g(rng), 0.3 * g(rng), 0.5 * g(rng));
    cams.push_back(Rigid3d(r, -(r * center)));
  }
  return cams;
}

TEST(FocalEstimation, RecoversTheFocalLengthOfHandHeldPhotos) {
  const int width = 640, height = 480;
  const double focal = 700;
  const std::vector<Rigid3d> cams = HandHeldCameras(4, 8, 15);
  std::vector<Eigen::Matrix3d> fundamentals;
  for (size_t i = 0; i < cams.size(); ++i)
    for (size_t j = i + 1; j < cams.size(); ++j) {
      const Rigid3d j_from_i = cams[j] * cams[i].Inverse();
      Eigen::Matrix3d f = FundamentalOf(j_from_i, focal, 320, 240);
      fundamentals.push_back(f / f.norm());
    }
  const FocalEstimate e = EstimateFocalFromFundamentals(fundamentals, width, height);
  EXPECT_EQ(e.num_pairs, 28);
  EXPECT_NEAR(e.focal_px, focal, 0.005 * focal);
  EXPECT_TRUE(e.distinct);
  EXPECT_LT(e.cost, 1e-4);
  // A wrong focal length leaves unequal singular values.
  EXPECT_GT(EssentialSingularValueGap(fundamentals[0], 1.3 * focal, 320, 240), 10 * e.cost);
}

TEST(FocalEstimation, TooFewPairsGiveNoEstimate) {
  const std::vector<Rigid3d> cams = HandHeldCameras(5, 2, 10);
  const Eigen::Matrix3d f = FundamentalOf(cams[1] * cams[0].Inverse(), 500, 320, 240);
  const FocalEstimate e = EstimateFocalFromFundamentals({f}, 640, 480);
  EXPECT_EQ(e.focal_px, 0);
  EXPECT_FALSE(e.distinct);
}

}  // namespace
}  // namespace nerfreg
