#include "nerfreg/geometry/sh_rotation.h"

#include <gtest/gtest.h>

#include <random>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {
namespace {

Eigen::Matrix3d RandomRotationMatrix(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  return RandomRotation(u(rng), u(rng), u(rng)).toRotationMatrix();
}

Eigen::Vector3d RandomDirection(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// The rotated coefficients give, at every direction d, the original function's value at R^T d:
// checked by evaluating both sums directly (brute force), for every degree.
TEST(ShRotation, MatchesBruteForceEvaluationAtRotatedDirections) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  for (int degree = 0; degree <= 3; ++degree) {
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Matrix3d r = RandomRotationMatrix(rng);
      Eigen::VectorXd c((degree + 1) * (degree + 1));
      for (int k = 0; k < c.size(); ++k) c(k) = n(rng);
      const Eigen::VectorXd rotated = ShRotationMatrix(r, degree) * c;
      for (int j = 0; j < 50; ++j) {
        const Eigen::Vector3d d = RandomDirection(rng);
        const double expected = c.dot(RealShBasis(r.transpose() * d, degree));
        EXPECT_NEAR(rotated.dot(RealShBasis(d, degree)), expected, 1e-12) << "degree " << degree;
      }
    }
  }
}

TEST(ShRotation, IsOrthogonalBlockDiagonalAndComposes) {
  std::mt19937 rng(4);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Matrix3d a = RandomRotationMatrix(rng), b = RandomRotationMatrix(rng);
    const Eigen::MatrixXd ma = ShRotationMatrix(a, 3), mb = ShRotationMatrix(b, 3);
    EXPECT_LT((ma.transpose() * ma - Eigen::MatrixXd::Identity(16, 16)).norm(), 1e-12);
    // f rotated by b, then by a, is f rotated by a b.
    EXPECT_LT((ShRotationMatrix(a * b, 3) - ma * mb).norm(), 1e-12);
    // The inverse rotation undoes it: what reg apply --inverse relies on.
    EXPECT_LT((ShRotationMatrix(a.transpose(), 3) * ma - Eigen::MatrixXd::Identity(16, 16)).norm(), 1e-12);
    // No coupling between degrees, and the DC term is untouched.
    EXPECT_NEAR(ma(0, 0), 1.0, 1e-12);
    EXPECT_LT(ma.block(1, 4, 3, 12).norm() + ma.block(4, 1, 12, 3).norm() + ma.block(9, 4, 7, 5).norm(), 1e-12);
  }
  EXPECT_LT((ShRotationMatrix(Eigen::Matrix3d::Identity(), 3) - Eigen::MatrixXd::Identity(16, 16)).norm(), 1e-12);
}

// Degree 1 in closed form: Y_1(d) = C1 P d with P (x, y, z) -> (-y, z, -x), so M = P R P^T.
TEST(ShRotation, DegreeOneIsTheRotationInPermutedAxes) {
  std::mt19937 rng(5);
  Eigen::Matrix3d p;
  p << 0, -1, 0, 0, 0, 1, -1, 0, 0;
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Matrix3d r = RandomRotationMatrix(rng);
    EXPECT_LT((ShRotationMatrix(r, 1).block(1, 1, 3, 3) - p * r * p.transpose()).norm(), 1e-12);
  }
}

TEST(ShRotation, BasisIsOrthonormalOverTheSphere) {
  // Monte Carlo would be slow to converge; a Fibonacci sphere of 20000 points integrates
  // polynomials of degree 6 to ~1e-4.
  const int n = 20000;
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(16, 16);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int j = 0; j < n; ++j) {
    const double z = 1.0 - 2.0 * (j + 0.5) / n, r = std::sqrt(1.0 - z * z);
    const Eigen::VectorXd y = RealShBasis(Eigen::Vector3d(r * std::cos(golden * j), r * std::sin(golden * j), z), 3);
    gram += y * y.transpose() * (4 * M_PI / n);
  }
  EXPECT_LT((gram - Eigen::MatrixXd::Identity(16, 16)).cwiseAbs().maxCoeff(), 1e-3);
}

}  // namespace
}  // namespace nerfreg
