#include "nerfreg/reg/splat_field.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "nerfreg/data/splat_test_util.h"
#include "nerfreg/reg/registration_input.h"

namespace nerfreg {
namespace {

// The field's definition written out independently of its code: every splat, no spatial hash.
double ReferenceDensity(const Splats& s, const SplatFieldOptions& o, const Eigen::Vector3d& x) {
  double sum = 0;
  for (std::int64_t i = 0; i < s.size(); ++i) {
    const Eigen::Vector4d q = s.rotation.col(i).cast<double>().normalized();
    const double w = q(0), a = q(1), b = q(2), c = q(3);
    Eigen::Matrix3d r;  // the quaternion's rotation matrix, written out
    r << 1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b),  //
        2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a),   //
        2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b);
    Eigen::Matrix3d cov = o.blur * o.blur * Eigen::Matrix3d::Identity();
    for (int k = 0; k < 3; ++k) cov += std::exp(2.0 * s.log_scale(k, i)) * r.col(k) * r.col(k).transpose();
    const Eigen::Vector3d d = x - s.position.col(i).cast<double>();
    const double m = d.dot(cov.ldlt().solve(d));
    if (m <= o.truncation * o.truncation)
      sum += o.density_scale / (1 + std::exp(-double(s.opacity(i)))) * std::exp(-0.5 * m);
  }
  return sum;
}

TEST(SplatField, DensityMatchesTheDirectSumOverEverySplat) {
  Splats s = RandomSplats(2000, 0, 21);
  // A few large splats (std 0.5-1.5): more cells than a splat may span, so every query visits them.
  for (int i = 0; i < 5; ++i) s.log_scale.col(i).setConstant(-0.5f + 0.2f * i);
  for (double blur : {0.0, 0.03}) {
    SplatFieldOptions o;
    o.blur = blur;
    const SplatField field(s, o);
    std::mt19937 rng(22);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    std::normal_distribution<double> near(0, 0.02);
    Eigen::Matrix3Xd points(3, 400);
    for (int q = 0; q < 400; ++q) {
      // Half the points close to a splat centre, where the sums are large.
      points.col(q) =
          q % 2 ? Eigen::Vector3d(u(rng), u(rng), u(rng))
                : Eigen::Vector3d(s.position.col(q).cast<double>()) + Eigen::Vector3d(near(rng), near(rng), near(rng));
    }
    const Eigen::VectorXd sigma = field.Density(points);
    int nonzero = 0;
    for (int q = 0; q < 400; ++q) {
      const double expected = ReferenceDensity(s, o, points.col(q));
      EXPECT_NEAR(sigma(q), expected, 1e-9 * std::max(1.0, expected)) << "point " << q << " blur " << blur;
      EXPECT_NEAR(field.DensityBySum(points.col(q)), expected, 1e-9 * std::max(1.0, expected));
      nonzero += expected > 1;
    }
    EXPECT_GT(nonzero, 200);  // the comparison covers real sums, not zeros
  }
}

TEST(SplatField, ColourIsTheDcTermWeightedByContribution) {
  Splats s = RandomSplats(2, 0, 23, false);
  s.position.col(0) = Eigen::Vector3f(0, 0, 0);
  s.position.col(1) = Eigen::Vector3f(5, 0, 0);  // far away: no overlap
  s.f_dc.col(0) = Eigen::Vector3f(1.0f, -1.0f, 5.0f);
  const SplatField field(s);
  Eigen::Matrix3Xd rgb;
  const Eigen::VectorXd sigma = field.Density(Eigen::Matrix3Xd::Zero(3, 1), &rgb);
  EXPECT_GT(sigma(0), 0);
  EXPECT_NEAR(rgb(0, 0), 0.5 + 0.28209479177387814, 1e-9);
  EXPECT_NEAR(rgb(1, 0), 0.5 - 0.28209479177387814, 1e-9);
  EXPECT_NEAR(rgb(2, 0), 1.0, 1e-12);  // clamped
  // Outside every splat's truncation box: nothing.
  Eigen::Matrix3Xd far(3, 1);
  far.col(0) = Eigen::Vector3d(2.5, 0, 0);
  EXPECT_EQ(field.Density(far, &rgb)(0), 0.0);
  EXPECT_TRUE(rgb.col(0).isZero());
  EXPECT_TRUE(field.Bounds().contains(Eigen::Vector3d(5, 0, 0)));
  EXPECT_FALSE(field.Bounds().contains(Eigen::Vector3d(7, 0, 0)));
}

// Splats on a sphere: the occupied points and the grid's mask lie on it, and the torch wrapper
// gives the field's own values.
TEST(SplatInput, OccupiedPointsAndGridLieOnTheSplattedSurface) {
  const int n = 3000;
  Splats s = RandomSplats(n, 1, 24);
  for (int i = 0; i < n; ++i) {
    s.position.col(i) = s.normal.col(i).normalized();
    s.log_scale.col(i).setConstant(std::log(0.03f));
    s.opacity(i) = 3;
  }
  SplatInput input(s, SplatFieldOptions());
  const Eigen::Matrix3Xd occupied = input.OccupiedPoints(5.0, 0);
  ASSERT_GT(occupied.cols(), 1000);
  for (Eigen::Index i = 0; i < occupied.cols(); ++i) EXPECT_NEAR(occupied.col(i).norm(), 1.0, 0.15);
  GridExtractionOptions go;
  const RegGrid g = input.ExtractGrid(go);
  EXPECT_EQ(g.source, "splats");
  const torch::Tensor masked = g.MaskedXyz();
  ASSERT_GT(masked.size(0), 200);
  EXPECT_LT((masked.norm(2, 1) - 1).abs().max().item<double>(), 0.2);
  const torch::Tensor p = torch::rand({50, 3}) * 2 - 1;
  const Eigen::Matrix3Xd pe = PointsToEigen(p).eval();
  const Eigen::VectorXd direct = input.field().Density(pe);
  const torch::Tensor wrapped = input.Field().density(p);
  for (int i = 0; i < 50; ++i) EXPECT_NEAR(wrapped[i].item<double>(), direct(i), 1e-4 * std::max(1.0, direct(i)));
}

}  // namespace
}  // namespace nerfreg
