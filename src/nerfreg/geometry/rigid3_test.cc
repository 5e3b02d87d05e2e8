#include "nerfreg/geometry/rigid3.h"

#include <gtest/gtest.h>

#include <random>

namespace nerfreg {
namespace {

Rigid3d RandomRigid(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1), t(-2, 2);
  return Rigid3d(RandomRotation(u(rng), u(rng), u(rng)), Eigen::Vector3d(t(rng), t(rng), t(rng)));
}

TEST(Rigid3d, ComposeInverseApply) {
  std::mt19937 rng(1);
  for (int i = 0; i < 20; ++i) {
    const Rigid3d b_from_a = RandomRigid(rng), c_from_b = RandomRigid(rng);
    const Eigen::Vector3d x_in_a(0.3, -1.2, 2.0);
    const Rigid3d c_from_a = c_from_b * b_from_a;
    EXPECT_LT((c_from_a * x_in_a - c_from_b * (b_from_a * x_in_a)).norm(), 1e-12);
    EXPECT_LT((b_from_a.Inverse() * (b_from_a * x_in_a) - x_in_a).norm(), 1e-12);
    EXPECT_LT((Rigid3d::FromMatrix(c_from_a.ToMatrix()).ToMatrix() - c_from_a.ToMatrix()).norm(), 1e-12);
  }
}

TEST(Rigid3d, ExpLogRoundTripAndMatchesMatrixExponential) {
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0, 1);
  for (int i = 0; i < 50; ++i) {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi(k) = n(rng);
    if (xi.head<3>().norm() > 3.0) xi.head<3>() *= 3.0 / xi.head<3>().norm();  // stay below pi
    const Rigid3d t = Rigid3d::Exp(xi);
    EXPECT_LT((t.Log() - xi).norm(), 1e-9) << xi.transpose();
    // Compare with the 4x4 matrix exponential of the twist, by a truncated series.
    Eigen::Matrix4d x = Eigen::Matrix4d::Zero();
    x.topLeftCorner<3, 3>() = Skew(xi.head<3>());
    x.topRightCorner<3, 1>() = xi.tail<3>();
    Eigen::Matrix4d e = Eigen::Matrix4d::Identity(), term = Eigen::Matrix4d::Identity();
    for (int k = 1; k < 40; ++k) {
      term = term * x / k;
      e += term;
    }
    EXPECT_LT((e - t.ToMatrix()).norm(), 1e-9);
  }
  EXPECT_LT(Rigid3d::Exp(Vector6d::Zero()).Log().norm(), 1e-15);
}

TEST(Rigid3d, FromMatrixRejectsNonRotation) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 0) = 2;
  EXPECT_THROW(Rigid3d::FromMatrix(m), std::invalid_argument);
  m = Eigen::Matrix4d::Identity();
  m(0, 0) = -1;  // reflection
  EXPECT_THROW(Rigid3d::FromMatrix(m), std::invalid_argument);
}

TEST(Sim3d, MatrixRoundTripComposeInverse) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 20; ++i) {
    const Sim3d a(0.5 + u(rng), RandomRotation(u(rng), u(rng), u(rng)), Eigen::Vector3d(u(rng), 1, -2));
    const Sim3d b = Sim3d::FromMatrix(a.ToMatrix());
    EXPECT_NEAR(b.scale, a.scale, 1e-12);
    EXPECT_LT((b.ToMatrix() - a.ToMatrix()).norm(), 1e-12);
    EXPECT_LT(((a * a.Inverse()).ToMatrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  }
}

TEST(Sim3d, TransformCameraKeepsProjections) {
  // A camera moved by S sees S * x exactly where it saw x (up to the scale of depths).
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  const Sim3d b_from_a(1.7, RandomRotation(u(rng), u(rng), u(rng)), Eigen::Vector3d(0.1, 0.2, -0.3));
  const Rigid3d cam_from_a = RandomRigid(rng);
  const Rigid3d cam_from_b = b_from_a.TransformCamera(cam_from_a);
  const Eigen::Vector3d x_in_a(0.2, 0.4, -0.7);
  const Eigen::Vector3d p_a = cam_from_a * x_in_a;
  const Eigen::Vector3d p_b = cam_from_b * (b_from_a * x_in_a);
  EXPECT_LT((p_b - 1.7 * p_a).norm(), 1e-12);
}

TEST(Metrics, RotationAndTranslationError) {
  const Eigen::Quaterniond a = Eigen::Quaterniond::Identity();
  const Eigen::Quaterniond b(Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(RotationErrorDeg(a, b), 30.0, 1e-9);
  EXPECT_NEAR(RotationErrorDeg(a.toRotationMatrix(), b.toRotationMatrix()), 30.0, 1e-6);
  // q and -q are the same rotation.
  EXPECT_NEAR(RotationErrorDeg(b, Eigen::Quaterniond(-b.coeffs())), 0.0, 1e-6);
  EXPECT_DOUBLE_EQ(TranslationError({1, 2, 2}, {0, 0, 0}), 3.0);
}

TEST(Metrics, DirectionAngleIgnoresLengthsAndCallsAZeroVectorOpposite) {
  EXPECT_NEAR(DirectionAngleDeg({1, 0, 0}, {5, 0, 0}), 0.0, 1e-12);
  EXPECT_NEAR(DirectionAngleDeg({1, 0, 0}, {0, 0.1, 0}), 90.0, 1e-12);
  EXPECT_NEAR(DirectionAngleDeg({1, 1, 0}, {-2, -2, 0}), 180.0, 1e-12);
  EXPECT_NEAR(DirectionAngleDeg({1, 0, 0}, {1, 1, 0}), 45.0, 1e-12);
  EXPECT_EQ(DirectionAngleDeg({0, 0, 0}, {1, 0, 0}), 180.0);
  EXPECT_EQ(DirectionAngleDeg({1, 0, 0}, {0, 0, 0}), 180.0);
}

}  // namespace
}  // namespace nerfreg
