#include "nerfreg/sfm/bundle_adjustment.h"
#include "nerfreg/posegraph/ceres_solve.h"
#include "nerfreg/sfm/reprojection_cost.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

namespace nerfreg {

void BundleAdjustmentOptions::Check() const {
  if (!(huber_scale_px > 0) || max_iterations < 0 || num_threads < 1 || dense_schur_max_cameras < 0)
    throw std::invalid_argument("BundleAdjustmentOptions: out of range");
}

namespace {

// Fisheye cameras: (fx * (x/z - x_n), fy * (y/z - y_n)) on undistorted normalised coordinates.
struct NormalizedCost {
  NormalizedCost(const Eigen::Vector3d& x_normalized, double fx, double fy) : xn_(x_normalized), fx_(fx), fy_(fy) {}
  template <typename T>
  bool operator()(const T* camera, const T* point, T* residual) const {
    T p[3];
    ceres::AngleAxisRotatePoint(camera, point, p);
    for (int k = 0; k < 3; ++k) p[k] += camera[3 + k];
    const T z = p[2] > T(1e-6) ? p[2] : T(1e-6);
    residual[0] = T(fx_) * (p[0] / z - T(xn_.x()));
    residual[1] = T(fy_) * (p[1] / z - T(xn_.y()));
    return true;
  }
  Eigen::Vector3d xn_;
  double fx_, fy_;
};

double SquaredErrorSum(const std::vector<Camera>& cameras, const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                       const std::vector<bool>& posed, const std::vector<Rigid3d>& cam_from_world,
                       const std::vector<SfmPoint>& points) {
  double sum = 0;
  for (const auto& point : points)
    for (const auto& e : point.elements) {
      if (!posed[e.image]) continue;
      const Eigen::Vector3d p = cam_from_world[e.image] * point.x_in_world;
      const double error = p.z() > 1e-6 ? (cameras[e.image].ImgFromCam(p) - keypoints[e.image][e.keypoint]).norm()
                                        : 1e3;  // behind: counted as a gross error
      sum += error * error;
    }
  return sum;
}

// Each refined group's focal standard deviation (pixels): the focal's marginal variance in the
// covariance of the solved problem (the gauge is fixed by the held camera and translation
// coordinate, and the focal does not depend on the gauge), times the residuals' variance per
// coordinate (2 * cost over the degrees of freedom; the Huber loss is applied as in the solve).
std::map<int, double> FocalStddevPx(ceres::Problem* problem, std::map<int, std::array<double, 3>>* intrinsics,
                                    double final_cost) {
  std::map<int, double> stddev;
  std::vector<std::pair<const double*, const double*>> blocks;
  std::vector<int> groups;  // blocks[i] is group groups[i]'s
  for (auto& [g, block] : *intrinsics)
    if (problem->HasParameterBlock(block.data()) && !problem->IsParameterBlockConstant(block.data())) {
      blocks.emplace_back(block.data(), block.data());
      groups.push_back(g);
    }
  if (blocks.empty()) return stddev;
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::SPARSE_QR;  // the full Jacobian is sparse and tall
  covariance_options.num_threads = 1;
  ceres::Covariance covariance(covariance_options);
  const bool ok = covariance.Compute(blocks, problem);
  const int dof = problem->NumResiduals() - problem->NumParameters();
  const double variance = dof > 0 ? 2.0 * final_cost / dof : 0.0;
  for (size_t i = 0; i < blocks.size(); ++i) {
    double c[9];
    if (!ok || !covariance.GetCovarianceBlock(blocks[i].first, blocks[i].first, c) || !(c[0] >= 0)) {
      stddev[groups[i]] = std::numeric_limits<double>::infinity();
      continue;
    }
    stddev[groups[i]] = std::sqrt(c[0] * variance);
  }
  return stddev;
}

}  // namespace

BundleAdjustmentSummary BundleAdjust(std::vector<Camera>* cameras, const std::vector<int>& camera_group,
                                     const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                     const std::vector<bool>& posed, int fixed_camera,
                                     std::vector<Rigid3d>* cam_from_world, std::vector<SfmPoint>* points,
                                     const BundleAdjustmentOptions& options) {
  options.Check();
  const int n = static_cast<int>(cameras->size());
  if (static_cast<int>(cam_from_world->size()) != n || static_cast<int>(posed.size()) != n ||
      static_cast<int>(keypoints.size()) != n || fixed_camera < 0 || fixed_camera >= n || !posed[fixed_camera] ||
      (!camera_group.empty() && static_cast<int>(camera_group.size()) != n)) {
    throw std::invalid_argument("BundleAdjust: inconsistent sizes or fixed camera");
  }
  std::vector<std::array<double, 6>> params(n);
  for (int k = 0; k < n; ++k) {
    const Eigen::Matrix3d r = (*cam_from_world)[k].RotationMatrix();
    ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(r.data()), params[k].data());
    for (int a = 0; a < 3; ++a) params[k][3 + a] = (*cam_from_world)[k].translation(a);
  }
  // One intrinsics block (focal, k1, k2) per group, from the group's first image.
  std::vector<int> group(n);
  for (int k = 0; k < n; ++k) group[k] = camera_group.empty() ? k : camera_group[k];
  std::map<int, std::array<double, 3>> intrinsics;
  for (int k = 0; k < n; ++k)
    if (!intrinsics.count(group[k])) intrinsics[group[k]] = {(*cameras)[k].fx, (*cameras)[k].k1, (*cameras)[k].k2};

  const bool refine_intrinsics = options.refine_focal || options.refine_distortion;
  ceres::Problem problem;
  BundleAdjustmentSummary summary;
  for (auto& point : *points) {
    for (const auto& e : point.elements) {
      if (!posed[e.image]) continue;
      const Camera& cam = (*cameras)[e.image];
      const Eigen::Vector2d& uv = keypoints[e.image][e.keypoint];
      ceres::LossFunction* loss = new ceres::HuberLoss(options.huber_scale_px);
      if (cam.model == CameraModel::kOpenCVFisheye) {
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<NormalizedCost, 2, 6, 3>(
                                     new NormalizedCost(cam.CamFromImg(uv), cam.fx, cam.fy)),
                                 loss, params[e.image].data(), point.x_in_world.data());
      } else if (refine_intrinsics) {
        problem.AddResidualBlock(new ReprojectionCost(uv, cam, true), loss, params[e.image].data(),
                                 point.x_in_world.data(), intrinsics[group[e.image]].data());
      } else {
        problem.AddResidualBlock(new ReprojectionCost(uv, cam, false), loss, params[e.image].data(),
                                 point.x_in_world.data());
      }
      ++summary.num_observations;
    }
  }
  if (summary.num_observations == 0) return summary;
  summary.initial_rms_px =
      std::sqrt(SquaredErrorSum(*cameras, keypoints, posed, *cam_from_world, *points) / summary.num_observations);
  for (auto& [g, block] : intrinsics) {
    if (!problem.HasParameterBlock(block.data())) continue;
    std::vector<int> held;
    if (!options.refine_focal) held.push_back(0);
    if (!options.refine_distortion) held.push_back(1), held.push_back(2);
    if (held.size() == 3)
      problem.SetParameterBlockConstant(block.data());
    else if (!held.empty())
      problem.SetManifold(block.data(), new ceres::SubsetManifold(3, held));
    if (options.refine_focal) problem.SetParameterLowerBound(block.data(), 0, 1e-3 * block[0]);
  }
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
  for (int k = 0; k < n; ++k) {
    if (k == fixed_camera || !posed[k] || !problem.HasParameterBlock(params[k].data())) continue;
    std::vector<int> held;
    if (!options.refine_rotations) held = {0, 1, 2};
    if (k == far) {
      const Eigen::Vector3d t = (*cam_from_world)[far].translation - (*cam_from_world)[far].rotation * fixed_center;
      int axis = 0;
      t.cwiseAbs().maxCoeff(&axis);
      held.push_back(3 + axis);
    }
    if (!held.empty()) problem.SetManifold(params[k].data(), new ceres::SubsetManifold(6, held));
  }
  int num_posed = 0;
  for (int k = 0; k < n; ++k) num_posed += posed[k] && problem.HasParameterBlock(params[k].data());
  const ceres::LinearSolverType solver =
      num_posed <= options.dense_schur_max_cameras ? ceres::DENSE_SCHUR : ceres::ITERATIVE_SCHUR;
  const ceres::Solver::Summary ceres_summary =
      SolveCeresProblem(&problem, options.max_iterations, solver, options.num_threads);
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary.iterations = static_cast<int>(ceres_summary.iterations.size());
  LOG_DEBUG("bundle adjustment: {} observations, {} iterations, {:.2f} s (jacobians {:.2f}, linear solver {:.2f}): {}",
            summary.num_observations, summary.iterations, ceres_summary.total_time_in_seconds,
            ceres_summary.jacobian_evaluation_time_in_seconds, ceres_summary.linear_solver_time_in_seconds,
            ceres_summary.message);
  if (options.refine_focal && options.estimate_focal_stddev) {
    const Timer timer;
    summary.focal_stddev_px = FocalStddevPx(&problem, &intrinsics, ceres_summary.final_cost);
    LOG_DEBUG("bundle adjustment: the focal's covariance in {:.2f} s", timer.Seconds());
  }
  for (int k = 0; k < n; ++k) {
    if (!posed[k]) continue;
    Eigen::Matrix3d r;
    ceres::AngleAxisToRotationMatrix(params[k].data(), ceres::ColumnMajorAdapter3x3(r.data()));
    (*cam_from_world)[k] = Rigid3d(r, Eigen::Vector3d(params[k][3], params[k][4], params[k][5]));
  }
  // Every image of a refined group takes its intrinsics, posed or not (an image left out still
  // shares the camera).
  for (int k = 0; k < n && (options.refine_focal || options.refine_distortion); ++k) {
    Camera& cam = (*cameras)[k];
    if (cam.model == CameraModel::kOpenCVFisheye) continue;
    const std::array<double, 3>& block = intrinsics[group[k]];
    const double aspect = cam.fy / cam.fx;
    cam.fx = block[0], cam.fy = block[0] * aspect, cam.k1 = block[1], cam.k2 = block[2];
  }
  summary.final_rms_px =
      std::sqrt(SquaredErrorSum(*cameras, keypoints, posed, *cam_from_world, *points) / summary.num_observations);
  return summary;
}

std::vector<int> SpreadPointSubset(const std::vector<SfmPoint>& points,
                                   const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                   const std::vector<Camera>& cameras, const std::vector<bool>& posed,
                                   int cells_per_side, int per_cell) {
  if (cells_per_side < 1 || per_cell < 1 || keypoints.size() != cameras.size() || posed.size() != cameras.size())
    throw std::invalid_argument("SpreadPointSubset: out of range or inconsistent sizes");
  std::vector<int> order(points.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return points[a].elements.size() > points[b].elements.size(); });
  const int cells = cells_per_side * cells_per_side;
  std::vector<int> taken_in(cameras.size() * cells, 0);
  auto cell_of = [&](const TrackElement& e) {
    const Camera& c = cameras[e.image];
    const Eigen::Vector2d& uv = keypoints[e.image][e.keypoint];
    const int x = std::clamp(static_cast<int>(uv.x() * cells_per_side / std::max(1, c.width)), 0, cells_per_side - 1);
    const int y = std::clamp(static_cast<int>(uv.y() * cells_per_side / std::max(1, c.height)), 0, cells_per_side - 1);
    return static_cast<size_t>(e.image) * cells + y * cells_per_side + x;
  };
  std::vector<int> subset;
  for (int k : order) {
    bool wanted = false;
    for (const auto& e : points[k].elements) wanted = wanted || (posed[e.image] && taken_in[cell_of(e)] < per_cell);
    if (!wanted) continue;
    subset.push_back(k);
    for (const auto& e : points[k].elements)
      if (posed[e.image]) ++taken_in[cell_of(e)];
  }
  std::sort(subset.begin(), subset.end());
  return subset;
}

BundleAdjustmentSummary BundleAdjust(const std::vector<Camera>& cameras,
                                     const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                     const std::vector<bool>& posed, int fixed_camera,
                                     std::vector<Rigid3d>* cam_from_world, std::vector<SfmPoint>* points,
                                     const BundleAdjustmentOptions& options) {
  if (options.refine_focal || options.refine_distortion)
    throw std::invalid_argument("BundleAdjust: refining intrinsics needs mutable cameras");
  std::vector<Camera> copy = cameras;
  return BundleAdjust(&copy, {}, keypoints, posed, fixed_camera, cam_from_world, points, options);
}

}  // namespace nerfreg
