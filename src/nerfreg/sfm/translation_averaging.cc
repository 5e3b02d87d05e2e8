#include "nerfreg/sfm/translation_averaging.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/posegraph/ceres_solve.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <stdexcept>

#include "nerfreg/sfm/rotation_averaging.h"

namespace nerfreg {

void TranslationAveragingOptions::Check() const {
  if (reweighting_rounds < 1 || !(cauchy_scale_deg > 0) || !(huber_scale > 0) || max_iterations < 0 ||
      !(max_edge_error_deg > 0)) {
    throw std::invalid_argument("TranslationAveragingOptions: out of range");
  }
}

namespace {

struct DirectionCost {
  explicit DirectionCost(const Eigen::Vector3d& d) : d_(d) {}
  template <typename T>
  bool operator()(const T* ci, const T* cj, T* residual) const {
    T v[3] = {cj[0] - ci[0], cj[1] - ci[1], cj[2] - ci[2]};
    const T norm = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + T(1e-12));
    for (int k = 0; k < 3; ++k) residual[k] = v[k] / norm - T(d_[k]);
    return true;
  }
  Eigen::Vector3d d_;
};

}  // namespace

TranslationAveragingResult AverageTranslations(const ViewGraph& graph,
                                               const std::vector<Eigen::Quaterniond>& cam_from_world,
                                               const std::vector<bool>& usable,
                                               const TranslationAveragingOptions& options) {
  options.Check();
  const int n = static_cast<int>(graph.names.size());
  if (static_cast<int>(cam_from_world.size()) != n)
    throw std::invalid_argument("AverageTranslations: one rotation per image");
  if (!usable.empty() && usable.size() != graph.edges.size())
    throw std::invalid_argument("AverageTranslations: usable has the wrong size");
  TranslationAveragingResult result;
  result.centers.assign(n, Eigen::Vector3d::Zero());
  result.edge_error_deg.assign(graph.edges.size(), 180.0);
  result.edge_inlier.assign(graph.edges.size(), false);
  std::vector<ViewGraphEdge> edges;  // usable ones, with their index into graph.edges
  std::vector<int> edge_index;
  for (size_t e = 0; e < graph.edges.size(); ++e)
    if (usable.empty() || usable[e]) edges.push_back(graph.edges[e]), edge_index.push_back(static_cast<int>(e));
  result.solved = LargestComponent(n, edges);
  for (int k = 0; k < n && result.root < 0; ++k)
    if (result.solved[k]) result.root = k;
  if (result.root < 0) return result;

  // Unknowns: the solved centres except the root's.
  std::vector<int> var(n, -1);
  int num_vars = 0;
  for (int k = 0; k < n; ++k)
    if (result.solved[k] && k != result.root) var[k] = num_vars++;
  std::vector<Eigen::Vector3d> dirs;  // world direction of c_j - c_i per usable edge (unused: zero)
  for (const auto& e : edges) {
    dirs.push_back(result.solved[e.i]
                       ? Eigen::Vector3d(-(cam_from_world[e.j].inverse() * e.j_from_i.translation).normalized())
                       : Eigen::Vector3d(Eigen::Vector3d::Zero()));
  }
  std::vector<double> weight(edges.size(), 1.0);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3 * num_vars);
  auto center = [&](int k) -> Eigen::Vector3d {
    return var[k] < 0 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(x.segment<3>(3 * var[k]));
  };
  for (int round = 0; round < options.reweighting_rounds; ++round) {
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(3 * num_vars, 3 * num_vars);
    for (size_t m = 0; m < edges.size(); ++m) {
      if (dirs[m].isZero()) continue;
      // Rows: S (c_j - c_i), S = skew(d); contribution w S^T S on the blocks of i and j.
      const Eigen::Matrix3d s = Skew(dirs[m]);
      const Eigen::Matrix3d sts = weight[m] * s.transpose() * s;
      const int vi = var[edges[m].i], vj = var[edges[m].j];
      if (vi >= 0) normal.block<3, 3>(3 * vi, 3 * vi) += sts;
      if (vj >= 0) normal.block<3, 3>(3 * vj, 3 * vj) += sts;
      if (vi >= 0 && vj >= 0) {
        normal.block<3, 3>(3 * vi, 3 * vj) -= sts;
        normal.block<3, 3>(3 * vj, 3 * vi) -= sts;
      }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(normal);
    x = eig.eigenvectors().col(0);
    double agreement = 0;
    for (size_t m = 0; m < edges.size(); ++m)
      agreement += weight[m] * dirs[m].dot(center(edges[m].j) - center(edges[m].i));
    if (agreement < 0) x = -x;
    for (size_t m = 0; m < edges.size(); ++m) {
      if (dirs[m].isZero()) continue;
      const double a = DirectionAngleDeg(center(edges[m].j) - center(edges[m].i), dirs[m]) / options.cauchy_scale_deg;
      weight[m] = 1.0 / (1.0 + a * a);
    }
  }
  for (int k = 0; k < n; ++k) result.centers[k] = center(k);

  ceres::Problem problem;
  for (size_t m = 0; m < edges.size(); ++m) {
    if (dirs[m].isZero()) continue;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<DirectionCost, 3, 3, 3>(new DirectionCost(dirs[m])),
                             new ceres::HuberLoss(options.huber_scale), result.centers[edges[m].i].data(),
                             result.centers[edges[m].j].data());
  }
  if (problem.NumResidualBlocks() > 0) {
    problem.SetParameterBlockConstant(result.centers[result.root].data());
    // The residual is scale-free: hold the largest coordinate of the farthest centre (from the
    // linear solution) so the normal equations are not singular in the scale direction.
    int far = -1;
    for (int k = 0; k < n; ++k)
      if (var[k] >= 0 && problem.HasParameterBlock(result.centers[k].data()) &&
          (far < 0 || result.centers[k].norm() > result.centers[far].norm())) {
        far = k;
      }
    if (far >= 0) {
      int axis = 0;
      result.centers[far].cwiseAbs().maxCoeff(&axis);
      problem.SetManifold(result.centers[far].data(), new ceres::SubsetManifold(3, {axis}));
    }
    SolveCeresProblem(&problem, options.max_iterations);
  }
  double mean_distance = 0;
  int count = 0;
  for (int k = 0; k < n; ++k)
    if (result.solved[k] && k != result.root)
      mean_distance += (result.centers[k] - result.centers[result.root]).norm(), ++count;
  mean_distance = count > 0 ? mean_distance / count : 1.0;
  for (int k = 0; k < n; ++k)
    if (result.solved[k])
      result.centers[k] = (result.centers[k] - result.centers[result.root]) / std::max(mean_distance, 1e-12);
  for (size_t m = 0; m < edges.size(); ++m) {
    if (dirs[m].isZero()) continue;
    const double a = DirectionAngleDeg(result.centers[edges[m].j] - result.centers[edges[m].i], dirs[m]);
    result.edge_error_deg[edge_index[m]] = a;
    result.edge_inlier[edge_index[m]] = a <= options.max_edge_error_deg;
  }
  return result;
}

}  // namespace nerfreg
