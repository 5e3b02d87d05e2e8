#include "nerfreg/sfm/pose_evaluation.h"

#include <Eigen/SVD>
#include <algorithm>
#include <stdexcept>

#include "nerfreg/geometry/alignment.h"
#include "nerfreg/util/stats.h"

namespace nerfreg {

namespace {

Eigen::Vector3d Center(const Rigid3d& cam_from_world) {
  return -(cam_from_world.rotation.conjugate() * cam_from_world.translation);
}

bool AlignRotationsAndCenters(const std::vector<Rigid3d>& est, const std::vector<Rigid3d>& gt, Sim3d* gt_from_est) {
  const int n = static_cast<int>(est.size());
  // world_gt_from_world_est = R_gt^T * R_est per camera; their chordal mean.
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (int k = 0; k < n; ++k) sum += gt[k].RotationMatrix().transpose() * est[k].RotationMatrix();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();
  Eigen::Vector3d mean_e = Eigen::Vector3d::Zero(), mean_g = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> ce(n), cg(n);
  for (int k = 0; k < n; ++k) {
    ce[k] = r * Center(est[k]);
    cg[k] = Center(gt[k]);
    mean_e += ce[k] / n;
    mean_g += cg[k] / n;
  }
  double num = 0, den = 0;
  for (int k = 0; k < n; ++k) {
    num += (ce[k] - mean_e).dot(cg[k] - mean_g);
    den += (ce[k] - mean_e).squaredNorm();
  }
  if (!(den > 1e-24) || !(num > 0)) return false;
  const double s = num / den;
  *gt_from_est = Sim3d(s, Eigen::Quaterniond(r), mean_g - s * mean_e);
  return true;
}

}  // namespace

PoseEvaluation EvaluatePoses(const std::vector<Rigid3d>& estimated, const std::vector<Rigid3d>& ground_truth,
                             PoseAlignment alignment) {
  if (estimated.size() != ground_truth.size()) throw std::invalid_argument("EvaluatePoses: sizes differ");
  const int n = static_cast<int>(estimated.size());
  PoseEvaluation out;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b)
      out.widest_baseline = std::max(out.widest_baseline, (Center(ground_truth[a]) - Center(ground_truth[b])).norm());
  if (n < 2) return out;
  if (alignment == PoseAlignment::kCenters) {
    Eigen::Matrix3Xd src(3, n), tgt(3, n);
    for (int k = 0; k < n; ++k) src.col(k) = Center(estimated[k]), tgt.col(k) = Center(ground_truth[k]);
    AlignmentOptions options;
    options.estimate_scale = true;
    out.aligned = EstimateSim3d(src, tgt, Eigen::VectorXd(), options, &out.gt_from_estimate);
  } else {
    out.aligned = AlignRotationsAndCenters(estimated, ground_truth, &out.gt_from_estimate);
  }
  if (!out.aligned) return out;
  for (int k = 0; k < n; ++k) {
    const Rigid3d moved = out.gt_from_estimate.TransformCamera(estimated[k]);
    out.rotation_error_deg.push_back(RotationErrorDeg(moved.rotation, ground_truth[k].rotation));
    out.center_error.push_back((Center(moved) - Center(ground_truth[k])).norm());
  }
  for (int k = 0; k < n; ++k)
    out.mean_rotation_deg += out.rotation_error_deg[k] / n, out.mean_center += out.center_error[k] / n;
  out.median_rotation_deg = Median(out.rotation_error_deg);
  out.median_center = Median(out.center_error);
  out.median_center_percent = out.widest_baseline > 0 ? 100 * out.median_center / out.widest_baseline : 0;
  return out;
}

}  // namespace nerfreg
