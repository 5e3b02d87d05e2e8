#include "nerfreg/geometry/alignment.h"

#include <gtest/gtest.h>

#include <random>

namespace nerfreg {
namespace {

Eigen::Matrix3Xd RandomPoints(std::mt19937& rng, int n) {
  std::normal_distribution<double> g(0, 1);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) = Eigen::Vector3d(g(rng), g(rng), g(rng));
  return p;
}

Eigen::Matrix3Xd Apply(const Sim3d& t, const Eigen::Matrix3Xd& p) {
  Eigen::Matrix3Xd out(3, p.cols());
  for (int i = 0; i < p.cols(); ++i) out.col(i) = t * Eigen::Vector3d(p.col(i));
  return out;
}

TEST(Alignment, RecoversRandomSim3AndRigid) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const Sim3d gt(0.3 + 2 * u(rng), RandomRotation(u(rng), u(rng), u(rng)),
                   Eigen::Vector3d(u(rng), -u(rng), 3 * u(rng)));
    const Eigen::Matrix3Xd src = RandomPoints(rng, 50);
    const Eigen::Matrix3Xd tgt = Apply(gt, src);
    AlignmentOptions opt;
    opt.estimate_scale = true;
    Sim3d est;
    ASSERT_TRUE(EstimateSim3d(src, tgt, Eigen::VectorXd(), opt, &est));
    EXPECT_NEAR(est.scale, gt.scale, 1e-9);
    EXPECT_LT(RotationErrorDeg(est.rotation, gt.rotation), 1e-6);
    EXPECT_LT((est.translation - gt.translation).norm(), 1e-9);

    const Sim3d gt_rigid(1.0, gt.rotation, gt.translation);
    Rigid3d rigid;
    ASSERT_TRUE(EstimateRigid3d(src, Apply(gt_rigid, src), Eigen::VectorXd(), &rigid));
    EXPECT_LT(RotationErrorDeg(rigid.rotation, gt.rotation), 1e-6);
  }
}

TEST(Alignment, WeightsIgnoreOutliers) {
  std::mt19937 rng(8);
  const Sim3d gt(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitY())),
                 Eigen::Vector3d(1, 2, 3));
  const Eigen::Matrix3Xd src = RandomPoints(rng, 40);
  Eigen::Matrix3Xd tgt = Apply(gt, src);
  Eigen::VectorXd w = Eigen::VectorXd::Ones(40);
  for (int i = 0; i < 10; ++i) {
    tgt.col(i) += Eigen::Vector3d(5, -5, 5);  // outliers
    w(i) = 0;
  }
  Rigid3d est;
  ASSERT_TRUE(EstimateRigid3d(src, tgt, w, &est));
  EXPECT_LT(RotationErrorDeg(est.rotation, gt.rotation), 1e-6);
  EXPECT_LT((est.translation - gt.translation).norm(), 1e-9);
  // Unweighted, the outliers pull the estimate away: the weights matter.
  ASSERT_TRUE(EstimateRigid3d(src, tgt, Eigen::VectorXd(), &est));
  EXPECT_GT((est.translation - gt.translation).norm(), 0.1);
}

TEST(Alignment, ReflectionCaseGivesProperRotation) {
  // Targets are a mirror image of the sources: the best proper rotation must still be returned.
  std::mt19937 rng(9);
  const Eigen::Matrix3Xd src = RandomPoints(rng, 30);
  Eigen::Matrix3Xd tgt = src;
  tgt.row(2) *= -1;
  Rigid3d est;
  ASSERT_TRUE(EstimateRigid3d(src, tgt, Eigen::VectorXd(), &est));
  EXPECT_NEAR(est.RotationMatrix().determinant(), 1.0, 1e-9);
}

TEST(Alignment, DegenerateInputsFailCleanly) {
  Rigid3d est;
  Eigen::Matrix3Xd two(3, 2);
  two << 0, 1, 0, 0, 0, 0;
  EXPECT_FALSE(EstimateRigid3d(two, two, Eigen::VectorXd(), &est));
  std::mt19937 rng(10);
  const Eigen::Matrix3Xd src = RandomPoints(rng, 10);
  EXPECT_FALSE(EstimateRigid3d(src, src, Eigen::VectorXd::Zero(10), &est));
  Eigen::Matrix3Xd line(3, 10);
  for (int i = 0; i < 10; ++i) line.col(i) = Eigen::Vector3d(i, 2 * i, 3 * i);
  EXPECT_FALSE(EstimateRigid3d(line, line, Eigen::VectorXd(), &est));
  Eigen::VectorXd neg = Eigen::VectorXd::Ones(10);
  neg(0) = -1;
  EXPECT_FALSE(EstimateRigid3d(src, src, neg, &est));
}

}  // namespace
}  // namespace nerfreg
