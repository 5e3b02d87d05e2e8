#include "nerfreg/sfm/rotation_averaging.h"
#include "nerfreg/posegraph/ceres_solve.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <queue>
#include <stdexcept>

namespace nerfreg {

void RotationAveragingOptions::Check() const {
  if (!(loss_scale_deg > 0) || max_iterations < 0 || !(max_edge_error_deg > 0)) {
    throw std::invalid_argument("RotationAveragingOptions: out of range");
  }
}

std::vector<bool> LargestComponent(int num_images, const std::vector<ViewGraphEdge>& edges) {
  std::vector<std::vector<int>> adjacent(num_images);
  for (const auto& e : edges) {
    adjacent[e.i].push_back(e.j);
    adjacent[e.j].push_back(e.i);
  }
  std::vector<int> component(num_images, -1);
  int best = -1, best_size = 0;
  for (int s = 0, c = 0; s < num_images; ++s) {
    if (component[s] >= 0) continue;
    int size = 0;
    std::vector<int> stack = {s};
    component[s] = c;
    while (!stack.empty()) {
      const int a = stack.back();
      stack.pop_back();
      ++size;
      for (int b : adjacent[a])
        if (component[b] < 0) component[b] = c, stack.push_back(b);
    }
    if (size > best_size) best = c, best_size = size;
    ++c;
  }
  std::vector<bool> in(num_images, false);
  for (int k = 0; k < num_images; ++k) in[k] = best_size >= 2 && component[k] == best;
  return in;
}

namespace {

// Residual: angle-axis of j_from_i_measured^T * R_j * R_i^T, scaled by a weight.
struct RelativeRotationCost {
  RelativeRotationCost(const Eigen::Quaterniond& j_from_i, double weight) : inv_(j_from_i.inverse()), weight_(weight) {}
  template <typename T>
  bool operator()(const T* qi, const T* qj, T* residual) const {
    Eigen::Map<const Eigen::Quaternion<T>> ri(qi), rj(qj);
    const Eigen::Quaternion<T> err = inv_.cast<T>() * rj * ri.conjugate();
    const T q[4] = {err.w(), err.x(), err.y(), err.z()};
    ceres::QuaternionToAngleAxis(q, residual);
    for (int k = 0; k < 3; ++k) residual[k] *= T(weight_);
    return true;
  }
  Eigen::Quaterniond inv_;
  double weight_;
};

}  // namespace

std::vector<int> TriangleSupport(const ViewGraph& graph, double max_error_deg) {
  const int n = static_cast<int>(graph.names.size());
  // Relative rotations j_from_i by (i, j) for both directions.
  std::vector<std::vector<int>> index(n, std::vector<int>(n, -1));
  for (size_t e = 0; e < graph.edges.size(); ++e) index[graph.edges[e].i][graph.edges[e].j] = static_cast<int>(e);
  auto relative = [&](int a, int b, Eigen::Quaterniond* b_from_a) {
    if (index[a][b] >= 0) {
      *b_from_a = graph.edges[index[a][b]].j_from_i.rotation;
    } else if (index[b][a] >= 0) {
      *b_from_a = graph.edges[index[b][a]].j_from_i.rotation.inverse();
    } else {
      return false;
    }
    return true;
  };
  std::vector<int> support(graph.edges.size(), 0);
  for (size_t e = 0; e < graph.edges.size(); ++e) {
    const ViewGraphEdge& edge = graph.edges[e];
    for (int m = 0; m < n; ++m) {
      Eigen::Quaterniond m_from_i, j_from_m;
      if (m == edge.i || m == edge.j || !relative(edge.i, m, &m_from_i) || !relative(m, edge.j, &j_from_m)) continue;
      support[e] += RotationErrorDeg(j_from_m * m_from_i, edge.j_from_i.rotation) <= max_error_deg;
    }
  }
  return support;
}

RotationAveragingResult AverageRotations(const ViewGraph& graph, const RotationAveragingOptions& options) {
  options.Check();
  const int n = static_cast<int>(graph.names.size());
  for (const auto& e : graph.edges)
    if (e.i < 0 || e.j < 0 || e.i >= n || e.j >= n || e.i == e.j)
      throw std::invalid_argument("AverageRotations: bad edge");
  RotationAveragingResult result;
  result.cam_from_world.assign(n, Eigen::Quaterniond::Identity());
  result.connected = LargestComponent(n, graph.edges);
  result.edge_error_deg.assign(graph.edges.size(), 180.0);
  result.edge_inlier.assign(graph.edges.size(), false);
  for (int k = 0; k < n && result.root < 0; ++k)
    if (result.connected[k]) result.root = k;
  if (result.root < 0) return result;

  // Spanning tree (Prim) of maximum priority = inliers * (1 + triangle support), chaining
  // R_j = R_ij * R_i from the root. Support: the third images m for which i -> m -> j agrees with
  // the edge, so a wrong edge with many matches (repeated texture) is not trusted for the init.
  const std::vector<int> support = TriangleSupport(graph, options.max_edge_error_deg);
  std::vector<std::vector<int>> incident(n);
  for (size_t e = 0; e < graph.edges.size(); ++e) {
    incident[graph.edges[e].i].push_back(static_cast<int>(e));
    incident[graph.edges[e].j].push_back(static_cast<int>(e));
  }
  std::vector<bool> done(n, false);
  std::priority_queue<std::pair<double, int>> heap;  // (priority, edge)
  auto visit = [&](int a) {
    done[a] = true;
    for (int e : incident[a]) heap.push({graph.edges[e].num_inliers * (1.0 + support[e]), e});
  };
  visit(result.root);
  while (!heap.empty()) {
    const ViewGraphEdge& e = graph.edges[heap.top().second];
    heap.pop();
    if (done[e.i] && done[e.j]) continue;
    if (done[e.i]) {
      result.cam_from_world[e.j] = (e.j_from_i.rotation * result.cam_from_world[e.i]).normalized();
      visit(e.j);
    } else {
      result.cam_from_world[e.i] = (e.j_from_i.rotation.inverse() * result.cam_from_world[e.j]).normalized();
      visit(e.i);
    }
  }

  // Robust refinement over every edge of the component.
  std::vector<int> inliers;
  for (const auto& e : graph.edges) inliers.push_back(e.num_inliers);
  std::nth_element(inliers.begin(), inliers.begin() + inliers.size() / 2, inliers.end());
  const double median_inliers = std::max(1, inliers.empty() ? 1 : inliers[inliers.size() / 2]);
  ceres::Problem problem;
  const double loss_scale = options.loss_scale_deg * M_PI / 180;
  for (const auto& e : graph.edges) {
    if (!result.connected[e.i]) continue;
    const double weight = std::sqrt(std::max(1, e.num_inliers) / median_inliers);
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativeRotationCost, 3, 4, 4>(
                                 new RelativeRotationCost(e.j_from_i.rotation, weight)),
                             new ceres::CauchyLoss(loss_scale), result.cam_from_world[e.i].coeffs().data(),
                             result.cam_from_world[e.j].coeffs().data());
  }
  for (int k = 0; k < n; ++k)
    if (result.connected[k] && problem.HasParameterBlock(result.cam_from_world[k].coeffs().data())) {
      problem.SetManifold(result.cam_from_world[k].coeffs().data(), new ceres::EigenQuaternionManifold);
    }
  problem.SetParameterBlockConstant(result.cam_from_world[result.root].coeffs().data());
  SolveCeresProblem(&problem, options.max_iterations);

  for (size_t k = 0; k < graph.edges.size(); ++k) {
    const ViewGraphEdge& e = graph.edges[k];
    if (!result.connected[e.i]) continue;
    result.cam_from_world[e.i].normalize();
    result.cam_from_world[e.j].normalize();
    const Eigen::Quaterniond predicted = result.cam_from_world[e.j] * result.cam_from_world[e.i].inverse();
    result.edge_error_deg[k] = RotationErrorDeg(predicted, e.j_from_i.rotation);
    result.edge_inlier[k] = result.edge_error_deg[k] <= options.max_edge_error_deg;
  }
  return result;
}

}  // namespace nerfreg
