#include "nerfreg/sfm/global_positioning.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <stdexcept>

#include "nerfreg/posegraph/ceres_solve.h"

namespace nerfreg {

void GlobalPositioningOptions::Check() const {
  if (!(huber_scale > 0) || max_iterations < 0 || max_tracks_per_image < 1 || min_track_length < 2 || num_threads < 1) {
    throw std::invalid_argument("GlobalPositioningOptions: out of range");
  }
}

namespace {

// v - s * (x - c): the ray v (world frame, unit) against the scaled camera-to-point vector.
struct RayCost {
  explicit RayCost(const Eigen::Vector3d& v) : v_(v) {}
  template <typename T>
  bool operator()(const T* c, const T* x, const T* s, T* residual) const {
    for (int k = 0; k < 3; ++k) residual[k] = T(v_[k]) - s[0] * (x[k] - c[k]);
    return true;
  }
  Eigen::Vector3d v_;
};

int FindRoot(std::vector<int>* parent, int a) {
  while ((*parent)[a] != a) a = (*parent)[a] = (*parent)[(*parent)[a]];
  return a;
}

}  // namespace

GlobalPositioningResult PositionCamerasAndPoints(const std::vector<Track>& tracks,
                                                 const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                                 const std::vector<Camera>& cameras,
                                                 const std::vector<Eigen::Quaterniond>& cam_from_world,
                                                 const std::vector<bool>& oriented,
                                                 const GlobalPositioningOptions& options) {
  options.Check();
  const int n = static_cast<int>(cameras.size());
  if (static_cast<int>(keypoints.size()) != n || static_cast<int>(cam_from_world.size()) != n ||
      static_cast<int>(oriented.size()) != n) {
    throw std::invalid_argument("PositionCamerasAndPoints: one camera, keypoint list and orientation per image");
  }
  GlobalPositioningResult result;
  result.centers.assign(n, Eigen::Vector3d::Zero());
  result.solved.assign(n, false);

  // Tracks, longest first, until every image has its quota; only oriented images' elements count.
  std::vector<int> length(tracks.size(), 0);
  for (size_t t = 0; t < tracks.size(); ++t)
    for (const auto& e : tracks[t].elements) length[t] += oriented[e.image];
  std::vector<int> order(tracks.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return length[a] > length[b]; });
  std::vector<int> per_image(n, 0);
  for (int t : order) {
    if (length[t] < options.min_track_length) break;
    bool wanted = false;
    for (const auto& e : tracks[t].elements)
      if (oriented[e.image] && per_image[e.image] < options.max_tracks_per_image) wanted = true;
    if (!wanted) continue;
    result.track_index.push_back(t);
    for (const auto& e : tracks[t].elements) per_image[e.image] += oriented[e.image];
  }

  // The largest set of images linked through shared tracks; images need a few observations.
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  for (int t : result.track_index) {
    int first = -1;
    for (const auto& e : tracks[t].elements) {
      if (!oriented[e.image]) continue;
      if (first < 0)
        first = e.image;
      else
        parent[FindRoot(&parent, e.image)] = FindRoot(&parent, first);
    }
  }
  constexpr int kMinObservations = 6;
  std::vector<int> component_size(n, 0);
  for (int k = 0; k < n; ++k)
    if (oriented[k] && per_image[k] >= kMinObservations) ++component_size[FindRoot(&parent, k)];
  const int best =
      static_cast<int>(std::max_element(component_size.begin(), component_size.end()) - component_size.begin());
  if (component_size[best] < 2) {
    result.track_index.clear();
    return result;
  }
  for (int k = 0; k < n; ++k)
    result.solved[k] = oriented[k] && per_image[k] >= kMinObservations && FindRoot(&parent, k) == best;

  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  auto random_point = [&]() { return Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)); };
  for (int k = 0; k < n; ++k)
    if (result.solved[k]) result.centers[k] = random_point();
  result.points.reserve(result.track_index.size());
  for (size_t p = 0; p < result.track_index.size(); ++p) result.points.push_back(random_point());

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss loss(options.huber_scale);
  std::vector<double> scales;
  scales.reserve(per_image.size() * options.max_tracks_per_image);
  for (size_t p = 0; p < result.track_index.size(); ++p)
    for (const auto& e : tracks[result.track_index[p]].elements)
      if (result.solved[e.image]) scales.push_back(1.0);
  size_t s = 0;
  for (size_t p = 0; p < result.track_index.size(); ++p) {
    for (const auto& e : tracks[result.track_index[p]].elements) {
      if (!result.solved[e.image]) continue;
      const Eigen::Vector3d ray_in_cam = cameras[e.image].CamFromImg(keypoints[e.image][e.keypoint]).normalized();
      const Eigen::Vector3d ray = cam_from_world[e.image].inverse() * ray_in_cam;
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RayCost, 3, 3, 3, 1>(new RayCost(ray)), &loss,
                               result.centers[e.image].data(), result.points[p].data(), &scales[s]);
      problem.SetParameterLowerBound(&scales[s], 0, 1e-5);
      ++s;
      ++result.num_observations;
    }
  }
  if (result.num_observations == 0) return result;
  const int root =
      static_cast<int>(std::find(result.solved.begin(), result.solved.end(), true) - result.solved.begin());
  result.centers[root].setZero();
  problem.SetParameterBlockConstant(result.centers[root].data());
  const ceres::Solver::Summary summary =
      SolveCeresProblem(&problem, options.max_iterations, ceres::SPARSE_SCHUR, options.num_threads);
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  return result;
}

}  // namespace nerfreg
