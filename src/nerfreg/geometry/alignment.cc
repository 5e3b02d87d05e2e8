#include "nerfreg/geometry/alignment.h"

#include <Eigen/SVD>
#include <stdexcept>

namespace nerfreg {

void AlignmentOptions::Check() const {
  if (!(min_total_weight > 0)) throw std::invalid_argument("AlignmentOptions: min_total_weight must be > 0");
}

bool EstimateSim3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                   const Eigen::VectorXd& weights, const AlignmentOptions& options,
                   Sim3d* tgt_from_src) {
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

bool EstimateRigid3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                     const Eigen::VectorXd& weights, Rigid3d* tgt_from_src) {
  Sim3d sim;
  if (!EstimateSim3d(src, tgt, weights, AlignmentOptions{}, &sim)) return false;
  *tgt_from_src = sim.ToRigid();
  return true;
}

}  // namespace nerfreg
