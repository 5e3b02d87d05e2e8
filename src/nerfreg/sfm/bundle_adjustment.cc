#include "nerfreg/sfm/bundle_adjustment.h"
#include "nerfreg/posegraph/ceres_solve.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <array>
#include <cmath>
#include <stdexcept>

namespace nerfreg {

void BundleAdjustmentOptions::Check() const {
  if (!(huber_scale_px > 0) || max_iterations < 0 || num_threads < 1)
    throw std::invalid_argument("BundleAdjustmentOptions: out of range");
}

namespace {

// Camera parameters: angle-axis rotation (3), translation (3) of cam_from_world.
struct ReprojectionCost {
  ReprojectionCost(const Eigen::Vector3d& x_normalized, double fx, double fy) : xn_(x_normalized), fx_(fx), fy_(fy) {}
  template <typename T>
  bool operator()(const T* camera, const T* point, T* residual) const {
    T p[3];
    ceres::AngleAxisRotatePoint(camera, point, p);
    for (int k = 0; k < 3; ++k) p[k] += camera[3 + k];
    // Points behind the camera keep a finite residual; triangulation removes them later.
    const T z = p[2] > T(1e-6) ? p[2] : T(1e-6);
    residual[0] = T(fx_) * (p[0] / z - T(xn_.x()));
    residual[1] = T(fy_) * (p[1] / z - T(xn_.y()));
    return true;
  }
  Eigen::Vector3d xn_;
  double fx_, fy_;
};

}  // namespace

BundleAdjustmentSummary BundleAdjust(const std::vector<Camera>& cameras,
                                     const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                     const std::vector<bool>& posed, int fixed_camera,
                                     std::vector<Rigid3d>* cam_from_world, std::vector<SfmPoint>* points,
                                     const BundleAdjustmentOptions& options) {
  options.Check();
  const int n = static_cast<int>(cameras.size());
  if (static_cast<int>(cam_from_world->size()) != n || static_cast<int>(posed.size()) != n ||
      static_cast<int>(keypoints.size()) != n || fixed_camera < 0 || fixed_camera >= n || !posed[fixed_camera]) {
    throw std::invalid_argument("BundleAdjust: inconsistent sizes or fixed camera");
  }
  std::vector<std::array<double, 6>> params(n);
  for (int k = 0; k < n; ++k) {
    const Eigen::Matrix3d r = (*cam_from_world)[k].RotationMatrix();
    ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(r.data()), params[k].data());
    for (int a = 0; a < 3; ++a) params[k][3 + a] = (*cam_from_world)[k].translation(a);
  }
  ceres::Problem problem;
  BundleAdjustmentSummary summary;
  double initial_sq = 0;
  for (auto& point : *points) {
    for (const auto& e : point.elements) {
      if (!posed[e.image]) continue;
      const Camera& cam = cameras[e.image];
      const Eigen::Vector3d xn = cam.CamFromImg(keypoints[e.image][e.keypoint]);
      auto* cost = new ReprojectionCost(xn, cam.fx, cam.fy);
      double r[2];
      (*cost)(params[e.image].data(), point.x_in_world.data(), r);
      initial_sq += r[0] * r[0] + r[1] * r[1];
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ReprojectionCost, 2, 6, 3>(cost),
                               new ceres::HuberLoss(options.huber_scale_px), params[e.image].data(),
                               point.x_in_world.data());
      ++summary.num_observations;
    }
  }
  if (summary.num_observations == 0) return summary;
  summary.initial_rms_px = std::sqrt(initial_sq / summary.num_observations);
  if (problem.HasParameterBlock(params[fixed_camera].data()))
    problem.SetParameterBlockConstant(params[fixed_camera].data());
  // The scale gauge: the largest translation coordinate of the camera farthest from the fixed one
  // (in its own frame, as COLMAP does) is held too.
  const Eigen::Vector3d fixed_center = (*cam_from_world)[fixed_camera].Inverse().translation;
  int far = -1;
  double far_distance = 0;
  for (int k = 0; k < n; ++k) {
    if (k == fixed_camera || !posed[k] || !problem.HasParameterBlock(params[k].data())) continue;
    const double d = ((*cam_from_world)[k].Inverse().translation - fixed_center).norm();
    if (d > far_distance) far = k, far_distance = d;
  }
  if (far >= 0) {
    const Eigen::Vector3d t = (*cam_from_world)[far].translation - (*cam_from_world)[far].rotation * fixed_center;
    int axis = 0;
    t.cwiseAbs().maxCoeff(&axis);
    problem.SetManifold(params[far].data(), new ceres::SubsetManifold(6, {3 + axis}));
  }
  const ceres::Solver::Summary ceres_summary =
      SolveCeresProblem(&problem, options.max_iterations, ceres::SPARSE_SCHUR, options.num_threads);
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary.iterations = static_cast<int>(ceres_summary.iterations.size());
  for (int k = 0; k < n; ++k) {
    if (!posed[k]) continue;
    Eigen::Matrix3d r;
    ceres::AngleAxisToRotationMatrix(params[k].data(), ceres::ColumnMajorAdapter3x3(r.data()));
    (*cam_from_world)[k] = Rigid3d(r, Eigen::Vector3d(params[k][3], params[k][4], params[k][5]));
  }
  double final_sq = 0;
  for (const auto& point : *points)
    for (const auto& e : point.elements) {
      if (!posed[e.image]) continue;
      const Camera& cam = cameras[e.image];
      const Eigen::Vector3d xn = cam.CamFromImg(keypoints[e.image][e.keypoint]);
      const Eigen::Vector3d p = (*cam_from_world)[e.image] * point.x_in_world;
      const double dx = cam.fx * (p.x() / p.z() - xn.x()), dy = cam.fy * (p.y() / p.z() - xn.y());
      final_sq += dx * dx + dy * dy;
    }
  summary.final_rms_px = std::sqrt(final_sq / summary.num_observations);
  return summary;
}

}  // namespace nerfreg
