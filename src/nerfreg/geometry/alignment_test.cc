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
  const Sim3d gt(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitY())), Eigen::Vector3d(1, 2, 3));
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

// Learned matches: most are wrong. Kabsch over all of them is pulled far off; RANSAC over the
// same weighted correspondences recovers the pose to the noise level, deterministically.
TEST(Alignment, RansacRecoversThePoseWithMostMatchesWrong) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  const Sim3d gt(1.0, RandomRotation(0.2, 0.7, 0.4), Eigen::Vector3d(0.5, -0.3, 0.8));
  const int n = 400;
  const Eigen::Matrix3Xd src = RandomPoints(rng, n);
  Eigen::Matrix3Xd tgt = Apply(gt, src);
  std::normal_distribution<double> noise(0, 0.005);
  Eigen::VectorXd w(n);
  for (int i = 0; i < n; ++i) {
    if (i % 10 < 7) {  // 70 % outliers: matched to another point of the target
      tgt.col(i) = Apply(gt, src.col((i * 37 + 5) % n));
    } else {
      tgt.col(i) += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
    w(i) = 0.5 + 0.5 * u(rng);
  }
  Rigid3d all;
  ASSERT_TRUE(EstimateRigid3d(src, tgt, w, &all));
  EXPECT_GT(RotationErrorDeg(all.rotation, gt.rotation), 5.0);

  RobustAlignmentOptions o;
  o.inlier_radius = 0.05;
  const RobustAlignmentResult r = EstimateSim3dRansac(src, tgt, w, o);
  ASSERT_TRUE(r.valid);
  EXPECT_LT(RotationErrorDeg(r.tgt_from_src.rotation, gt.rotation), 0.5);
  EXPECT_LT((r.tgt_from_src.translation - gt.translation).norm(), 0.01);
  EXPECT_NEAR(r.inlier_weight_fraction, 0.3, 0.05);
  EXPECT_GE(r.inliers, 110);
  const RobustAlignmentResult again = EstimateSim3dRansac(src, tgt, w, o);
  EXPECT_EQ(again.tgt_from_src.ToMatrix(), r.tgt_from_src.ToMatrix());

  // Scale too, when asked.
  const Sim3d gt_sim(1.7, gt.rotation, gt.translation);
  Eigen::Matrix3Xd tgt_sim = Apply(gt_sim, src);
  for (int i = 0; i < n; ++i) {
    if (i % 10 < 6) tgt_sim.col(i) = Apply(gt_sim, src.col((i * 37 + 5) % n));
  }
  o.estimate_scale = true;
  const RobustAlignmentResult s = EstimateSim3dRansac(src, tgt_sim, Eigen::VectorXd(), o);
  ASSERT_TRUE(s.valid);
  EXPECT_NEAR(s.tgt_from_src.scale, 1.7, 1e-6);
  EXPECT_LT(RotationErrorDeg(s.tgt_from_src.rotation, gt.rotation), 1e-4);
}

TEST(Alignment, RansacDegenerateInputsAreInvalidNotErrors) {
  std::mt19937 rng(3);
  const Eigen::Matrix3Xd src = RandomPoints(rng, 20);
  RobustAlignmentOptions o;
  // Weight on two points only.
  Eigen::VectorXd w = Eigen::VectorXd::Zero(20);
  w(0) = w(1) = 1;
  EXPECT_FALSE(EstimateSim3dRansac(src, src, w, o).valid);
  // All points on a line: no hypothesis is well posed.
  Eigen::Matrix3Xd line(3, 20);
  for (int i = 0; i < 20; ++i) line.col(i) = Eigen::Vector3d(0.1 * i, 0.2 * i, 0);
  EXPECT_FALSE(EstimateSim3dRansac(line, line, Eigen::VectorXd(), o).valid);
  // Non-finite points carry no weight instead of poisoning the result.
  Eigen::Matrix3Xd bad = src;
  bad(0, 3) = std::nan("");
  const RobustAlignmentResult r = EstimateSim3dRansac(bad, src, Eigen::VectorXd(), o);
  ASSERT_TRUE(r.valid);
  EXPECT_LT(RotationErrorDeg(r.tgt_from_src.rotation, Eigen::Quaterniond::Identity()), 1e-6);
  EXPECT_THROW(EstimateSim3dRansac(src, src.leftCols(5), Eigen::VectorXd(), o), std::invalid_argument);
  o.inlier_radius = 0;
  EXPECT_THROW(EstimateSim3dRansac(src, src, Eigen::VectorXd(), o), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
