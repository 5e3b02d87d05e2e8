#include "nerfreg/registration/scale_normalization.h"

#include <gtest/gtest.h>

#include <random>

#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

// Points on an ellipsoid's surface with a few far floaters.
Eigen::Matrix3Xd Ellipsoid(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    p.col(i) = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized().cwiseProduct(Eigen::Vector3d(1.2, 0.7, 0.4));
  }
  for (int i = 0; i < n / 100; ++i) p.col(i) = Eigen::Vector3d(40.0 + i, -30, 25);  // 1 % floaters
  return p;
}

TEST(ScaleNormalization, RadiusFollowsTheScaleAndIgnoresRotationTranslationAndFloaters) {
  const Eigen::Matrix3Xd p = Ellipsoid(5000, 1);
  Eigen::Vector3d c;
  const double r = OccupiedRadius(p, &c);
  EXPECT_LT(c.norm(), 0.05);  // the floaters dropped
  EXPECT_GT(r, 0.4);
  EXPECT_LT(r, 1.2);
  const Sim3d moved(2.5, Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, 3).normalized())),
                    Eigen::Vector3d(10, -4, 7));
  Eigen::Matrix3Xd q(3, p.cols());
  for (Eigen::Index i = 0; i < p.cols(); ++i) q.col(i) = moved * Eigen::Vector3d(p.col(i));
  Eigen::Vector3d cq;
  EXPECT_NEAR(OccupiedRadius(q, &cq), 2.5 * r, 1e-9 * r);
  EXPECT_LT((cq - moved * c).norm(), 1e-9);

  // Each normalised to the same radius and centre: the normalised frames differ by the rotation
  // alone.
  const Sim3d np = NormalizationFor(p, "p"), nq = NormalizationFor(q, "q");
  EXPECT_NEAR(np.scale, kNormalizedRadius / r, 1e-12);
  const Sim3d between = nq * moved * np.Inverse();
  EXPECT_NEAR(between.scale, 1.0, 1e-9);
  EXPECT_LT(between.translation.norm(), 1e-9);
}

TEST(ScaleNormalization, DegenerateInputsAndScalesOutOfRangeAreNamedErrors) {
  EXPECT_EQ(OccupiedRadius(Eigen::Matrix3Xd(3, 0)), 0);
  try {
    NormalizationFor(Eigen::Matrix3Xd::Zero(3, 20), "a.ply");
    FAIL() << "no error for points at one place";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("a.ply: occupied cells: expected", 0), 0u) << e.what();
  }
  const Eigen::Matrix3Xd huge = Ellipsoid(500, 2) * 1e5;
  EXPECT_THROW(NormalizationFor(huge, "huge.ply"), InputError);
  EXPECT_NO_THROW(CheckScaleInRange(1e-3, "T.json", "scale"));
  EXPECT_NO_THROW(CheckScaleInRange(1e3, "T.json", "scale"));
  try {
    CheckScaleInRange(2e3, "T.json", "scale");
    FAIL() << "no error for a scale of 2000";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "T.json: scale: expected a scale in [0.001, 1000], got 2000");
  }
}

}  // namespace
}  // namespace nerfreg
