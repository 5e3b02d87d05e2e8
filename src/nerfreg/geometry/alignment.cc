#include "nerfreg/geometry/alignment.h"

#include <Eigen/SVD>
#include <algorithm>
#include <random>
#include <stdexcept>
#include <vector>

namespace nerfreg {

void AlignmentOptions::Check() const {
  if (!(min_total_weight > 0)) throw std::invalid_argument("AlignmentOptions: min_total_weight must be > 0");
}

bool EstimateSim3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Eigen::VectorXd& weights,
                   const AlignmentOptions& options, Sim3d* tgt_from_src) {
  options.Check();
  const Eigen::Index n = src.cols();
  if (tgt.cols() != n) throw std::invalid_argument("EstimateSim3d: src and tgt sizes differ");
  if (weights.size() != 0 && weights.size() != n) {
    throw std::invalid_argument("EstimateSim3d: weights size differs from the point count");
  }
  Eigen::VectorXd w = weights.size() == 0 ? Eigen::VectorXd::Ones(n) : weights;
  if ((w.array() < 0).any() || !w.allFinite() || !src.allFinite() || !tgt.allFinite()) return false;
  if ((w.array() > 0).count() < 3) return false;
  const double total = w.sum();
  if (!(total > options.min_total_weight)) return false;
  w /= total;

  const Eigen::Vector3d mu_s = src * w;
  const Eigen::Vector3d mu_t = tgt * w;
  const Eigen::Matrix3Xd ds = src.colwise() - mu_s;
  const Eigen::Matrix3Xd dt = tgt.colwise() - mu_t;
  // Weighted cross-covariance (target x source) and source variance.
  const Eigen::Matrix3d cov = dt * w.asDiagonal() * ds.transpose();
  const double var_s = (ds.array().square().rowwise() * w.transpose().array()).sum();
  if (!(var_s > 1e-18)) return false;

  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  // Collinear points: the rotation about their line is undetermined.
  if (sv(1) <= 1e-12 * std::max(1.0, sv(0))) return false;
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  // Reflection fix: force det(R) = +1 by flipping the weakest direction.
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) d(2, 2) = -1;
  const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();
  const double scale = options.estimate_scale ? (sv.asDiagonal() * d).trace() / var_s : 1.0;
  if (!(scale > 0) || !std::isfinite(scale)) return false;
  const Eigen::Vector3d t = mu_t - scale * r * mu_s;
  *tgt_from_src = Sim3d(scale, Eigen::Quaterniond(r), t);
  return true;
}

void RobustAlignmentOptions::Check() const {
  if (!(inlier_radius > 0)) throw std::invalid_argument("RobustAlignmentOptions: inlier_radius must be > 0");
  if (iterations < 1) throw std::invalid_argument("RobustAlignmentOptions: iterations must be >= 1");
  if (refine_iterations < 0) throw std::invalid_argument("RobustAlignmentOptions: refine_iterations must be >= 0");
}

namespace {

// Truncated quadratic score of a pose and its inlier mask.
double ScorePose(const Sim3d& pose, const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Eigen::VectorXd& w,
                 double radius, Eigen::VectorXd* inlier_w) {
  const Eigen::Matrix3Xd moved = pose.TransformPoints(src);
  const Eigen::VectorXd d2 = (moved - tgt).colwise().squaredNorm().transpose();
  const double r2 = radius * radius;
  double score = 0;
  if (inlier_w) inlier_w->setZero(w.size());
  for (Eigen::Index i = 0; i < w.size(); ++i) {
    if (d2(i) < r2) {
      score += w(i) * (1 - d2(i) / r2);
      if (inlier_w) (*inlier_w)(i) = w(i);
    }
  }
  return score;
}

}  // namespace

RobustAlignmentResult EstimateSim3dRansac(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                                          const Eigen::VectorXd& weights, const RobustAlignmentOptions& options) {
  options.Check();
  const Eigen::Index n = src.cols();
  if (tgt.cols() != n) throw std::invalid_argument("EstimateSim3dRansac: src and tgt sizes differ");
  if (weights.size() != 0 && weights.size() != n) {
    throw std::invalid_argument("EstimateSim3dRansac: weights size differs from the point count");
  }
  RobustAlignmentResult result;
  Eigen::VectorXd w = weights.size() == 0 ? Eigen::VectorXd::Ones(n) : weights;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(w(i) > 0) || !std::isfinite(w(i)) || !src.col(i).allFinite() || !tgt.col(i).allFinite()) w(i) = 0;
  }
  if ((w.array() > 0).count() < 3) return result;
  const double total = w.sum();

  AlignmentOptions fit;
  fit.estimate_scale = options.estimate_scale;
  std::mt19937 rng(options.seed);
  std::discrete_distribution<Eigen::Index> draw(w.data(), w.data() + n);
  // Three points closer than this to each other (or to a line) give an ill-conditioned pose.
  const double min_spread = options.inlier_radius;
  double best_score = -1;
  Sim3d best;
  for (int it = 0; it < options.iterations; ++it) {
    const Eigen::Index a = draw(rng), b = draw(rng), c = draw(rng);
    if (a == b || b == c || a == c) continue;
    Eigen::Matrix3d s3, t3;
    s3 << src.col(a), src.col(b), src.col(c);
    t3 << tgt.col(a), tgt.col(b), tgt.col(c);
    // Both triangles must be non-degenerate: the smallest edge and the height over the longest.
    bool degenerate = false;
    for (const Eigen::Matrix3d* m : {&s3, &t3}) {
      const Eigen::Vector3d e0 = m->col(1) - m->col(0), e1 = m->col(2) - m->col(0);
      const double area2 = e0.cross(e1).norm();
      const double longest = std::max({e0.norm(), e1.norm(), (m->col(2) - m->col(1)).norm()});
      if (longest < min_spread || area2 / longest < 0.5 * min_spread) degenerate = true;
    }
    if (degenerate) continue;
    Sim3d pose;
    if (!EstimateSim3d(s3, t3, Eigen::VectorXd(), fit, &pose)) continue;
    const double score = ScorePose(pose, src, tgt, w, options.inlier_radius, nullptr);
    if (score > best_score) {
      best_score = score;
      best = pose;
    }
  }
  if (best_score < 0) return result;
  Eigen::VectorXd inlier_w;
  ScorePose(best, src, tgt, w, options.inlier_radius, &inlier_w);
  for (int r = 0; r < options.refine_iterations; ++r) {
    Sim3d refined;
    if (!EstimateSim3d(src, tgt, inlier_w, fit, &refined)) break;
    Eigen::VectorXd refined_w;
    const double score = ScorePose(refined, src, tgt, w, options.inlier_radius, &refined_w);
    if (score < best_score) break;  // refinement only keeps improvements
    best_score = score;
    best = refined;
    inlier_w = refined_w;
  }
  result.tgt_from_src = best;
  result.inliers = static_cast<int>((inlier_w.array() > 0).count());
  result.inlier_weight_fraction = total > 0 ? inlier_w.sum() / total : 0;
  result.valid = true;
  return result;
}

bool EstimateRigid3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Eigen::VectorXd& weights,
                     Rigid3d* tgt_from_src) {
  Sim3d sim;
  if (!EstimateSim3d(src, tgt, weights, AlignmentOptions{}, &sim)) return false;
  *tgt_from_src = sim.ToRigid();
  return true;
}

}  // namespace nerfreg
