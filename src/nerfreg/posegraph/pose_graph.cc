#include "nerfreg/posegraph/pose_graph.h"
#include "nerfreg/posegraph/ceres_solve.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <queue>
#include <stdexcept>

namespace nerfreg {

void PoseGraphOptions::Check() const {
  if (!(loss_scale > 0) || !(translation_weight > 0) || !(scale_weight > 0) || max_iterations <= 0 ||
      !(max_rotation_error_deg > 0) || !(max_translation_error > 0) || !(max_log_scale_error > 0)) {
    throw std::invalid_argument("PoseGraphOptions: all scales, weights and limits must be positive");
  }
}

namespace {

void CheckEdges(int num_nodes, const std::vector<PoseGraphEdge>& edges) {
  if (num_nodes <= 0) throw std::invalid_argument("OptimizePoseGraph: no nodes");
  for (const auto& e : edges) {
    if (e.i < 0 || e.j < 0 || e.i >= num_nodes || e.j >= num_nodes || e.i == e.j || !(e.weight > 0) ||
        !(e.j_from_i.scale > 0)) {
      throw std::invalid_argument("OptimizePoseGraph: bad edge " + std::to_string(e.i) + "->" + std::to_string(e.j));
    }
  }
}

// Residual of one edge for world_from_i = (q_i, t_i, s_i = exp(l_i)) and world_from_j likewise:
// predicted j_from_i = world_from_j^-1 * world_from_i. Rotation: 2 * vec(q_meas^-1 * q_pred) (the
// rotation vector for small errors); translation, in world units: t_i - (t_j + s_j R_j t_meas),
// where node i's origin lands by its own pose against through node j and the edge (for a rigid
// graph its norm is that of t_pred - t_meas); scale: l_i - l_j - log(s_meas). All scaled by the
// square root of the edge weight.
struct RelativePoseCost {
  RelativePoseCost(const Sim3d& j_from_i, double sqrt_weight, double translation_weight, double scale_weight)
      : q_meas(j_from_i.rotation),
        t_meas(j_from_i.translation),
        log_s_meas(std::log(j_from_i.scale)),
        w(sqrt_weight),
        wt(translation_weight),
        ws(scale_weight) {}

  template <typename T>
  bool operator()(const T* qi_, const T* ti_, const T* li, const T* qj_, const T* tj_, const T* lj, T* res) const {
    Eigen::Map<const Eigen::Quaternion<T>> qi(qi_), qj(qj_);
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> ti(ti_), tj(tj_);
    const Eigen::Quaternion<T> q_pred = qj.conjugate() * qi;
    const Eigen::Quaternion<T> q_err = q_meas.cast<T>().conjugate() * q_pred;
    const Eigen::Matrix<T, 3, 1> t_err = ti - tj - exp(lj[0]) * (qj * t_meas.cast<T>());
    // q and -q are one rotation: take the sign with a non-negative real part.
    const T sign = q_err.w() < T(0) ? T(-1) : T(1);
    for (int k = 0; k < 3; ++k) {
      res[k] = T(w) * T(2) * sign * q_err.vec()[k];
      res[3 + k] = T(w * wt) * t_err[k];
    }
    res[6] = T(w * ws) * (li[0] - lj[0] - T(log_s_meas));
    return true;
  }

  Eigen::Quaterniond q_meas;
  Eigen::Vector3d t_meas;
  double log_s_meas;
  double w, wt, ws;
};

// The three errors of an edge against the fused poses, as the residual measures them (unweighted).
void EdgeErrors(const PoseGraphEdge& e, const std::vector<Sim3d>& world_from_node, double* rotation_deg,
                double* translation, double* log_scale) {
  const Sim3d& wi = world_from_node[e.i];
  const Sim3d& wj = world_from_node[e.j];
  const Sim3d pred = wj.Inverse() * wi;
  *rotation_deg = RotationErrorDeg(pred.rotation, e.j_from_i.rotation);
  *translation = (wi.translation - wj.translation - wj.scale * (wj.rotation * e.j_from_i.translation)).norm();
  *log_scale = std::abs(std::log(pred.scale / e.j_from_i.scale));
}

bool EdgeIsInlier(double rotation_deg, double translation, double log_scale, const PoseGraphOptions& o) {
  return rotation_deg <= o.max_rotation_error_deg && translation <= o.max_translation_error &&
         log_scale <= o.max_log_scale_error;
}

}  // namespace

std::vector<double> TriangleSupport(int num_nodes, const std::vector<PoseGraphEdge>& edges, double max_rotation_deg,
                                    double max_translation, double max_log_scale) {
  // b_from_a for every measured ordered pair (either direction of an edge).
  std::map<std::pair<int, int>, Sim3d> rel;
  for (const auto& e : edges) {
    rel[{e.i, e.j}] = e.j_from_i;
    rel[{e.j, e.i}] = e.j_from_i.Inverse();
  }
  std::vector<double> support(edges.size(), 0.0);
  for (size_t k = 0; k < edges.size(); ++k) {
    const auto& e = edges[k];
    for (int m = 0; m < num_nodes; ++m) {
      if (m == e.i || m == e.j) continue;
      auto im = rel.find({e.i, m});
      auto mj = rel.find({m, e.j});
      if (im == rel.end() || mj == rel.end()) continue;
      const Sim3d via_m = mj->second * im->second;  // j_from_m * m_from_i
      if (RotationErrorDeg(via_m.rotation, e.j_from_i.rotation) <= max_rotation_deg &&
          TranslationError(via_m.translation, e.j_from_i.translation) <= max_translation &&
          std::abs(std::log(via_m.scale / e.j_from_i.scale)) <= max_log_scale) {
        support[k] += 1.0;
      }
    }
  }
  return support;
}

std::vector<Sim3d> InitializeFromSpanningTree(int num_nodes, const std::vector<PoseGraphEdge>& edges,
                                              std::vector<bool>* connected) {
  CheckEdges(num_nodes, edges);
  // A wrong registration taken into the tree would put its node far from the optimum, where the
  // robust loss cannot pull it back. Edges that close consistent triangles are preferred: the
  // tree's priority is the weight times (1 + number of consistent triangles through the edge).
  const PoseGraphOptions defaults;
  const std::vector<double> support =
      TriangleSupport(num_nodes, edges, 3 * defaults.max_rotation_error_deg, 3 * defaults.max_translation_error,
                      3 * defaults.max_log_scale_error);
  std::vector<Sim3d> world_from_node(num_nodes);
  connected->assign(num_nodes, false);
  (*connected)[0] = true;
  // Prim's algorithm on weights: always add the heaviest edge leaving the tree.
  using Item = std::pair<double, int>;  // weight, edge index
  std::priority_queue<Item> queue;
  auto push_edges_of = [&](int node) {
    for (size_t k = 0; k < edges.size(); ++k) {
      if (edges[k].i == node || edges[k].j == node) {
        queue.push({edges[k].weight * (1.0 + support[k]), static_cast<int>(k)});
      }
    }
  };
  push_edges_of(0);
  while (!queue.empty()) {
    const PoseGraphEdge& e = edges[queue.top().second];
    queue.pop();
    const bool has_i = (*connected)[e.i], has_j = (*connected)[e.j];
    if (has_i == has_j) continue;
    if (has_i) {  // world_from_j = world_from_i * i_from_j
      world_from_node[e.j] = world_from_node[e.i] * e.j_from_i.Inverse();
      (*connected)[e.j] = true;
      push_edges_of(e.j);
    } else {
      world_from_node[e.i] = world_from_node[e.j] * e.j_from_i;
      (*connected)[e.i] = true;
      push_edges_of(e.i);
    }
  }
  return world_from_node;
}

PoseGraphResult OptimizePoseGraph(int num_nodes, const std::vector<PoseGraphEdge>& measured,
                                  const PoseGraphOptions& options) {
  options.Check();
  // A rigid graph reads the edges without their scales.
  std::vector<PoseGraphEdge> edges = measured;
  if (!options.estimate_scale)
    for (auto& e : edges) e.j_from_i.scale = 1.0;
  PoseGraphResult result;
  result.world_from_node = InitializeFromSpanningTree(num_nodes, edges, &result.connected);

  std::vector<Eigen::Quaterniond> q(num_nodes);
  std::vector<Eigen::Vector3d> t(num_nodes);
  std::vector<double> log_s(num_nodes);
  for (int k = 0; k < num_nodes; ++k) {
    q[k] = result.world_from_node[k].rotation;
    t[k] = result.world_from_node[k].translation;
    log_s[k] = std::log(result.world_from_node[k].scale);
  }
  ceres::Problem problem;
  int used_edges = 0;
  for (const auto& e : edges) {
    if (!result.connected[e.i] || !result.connected[e.j]) continue;
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseCost, 7, 4, 3, 1, 4, 3, 1>(
        new RelativePoseCost(e.j_from_i, std::sqrt(e.weight), options.translation_weight, options.scale_weight));
    problem.AddResidualBlock(cost, new ceres::CauchyLoss(options.loss_scale), q[e.i].coeffs().data(), t[e.i].data(),
                             &log_s[e.i], q[e.j].coeffs().data(), t[e.j].data(), &log_s[e.j]);
    ++used_edges;
  }
  if (used_edges > 0) {
    for (int k = 0; k < num_nodes; ++k) {
      if (!problem.HasParameterBlock(q[k].coeffs().data())) continue;
      problem.SetManifold(q[k].coeffs().data(), new ceres::EigenQuaternionManifold);
      if (!options.estimate_scale) problem.SetParameterBlockConstant(&log_s[k]);
    }
    // Node 0 is the world frame: its pose and its scale.
    if (problem.HasParameterBlock(q[0].coeffs().data())) {
      problem.SetParameterBlockConstant(q[0].coeffs().data());
      problem.SetParameterBlockConstant(t[0].data());
      problem.SetParameterBlockConstant(&log_s[0]);
    }
    const ceres::Solver::Summary summary = SolveCeresProblem(&problem, options.max_iterations);
    result.initial_cost = summary.initial_cost;
    result.final_cost = summary.final_cost;
    result.converged = summary.termination_type == ceres::CONVERGENCE;
  } else {
    result.converged = true;
  }
  for (int k = 0; k < num_nodes; ++k) result.world_from_node[k] = Sim3d(std::exp(log_s[k]), q[k], t[k]);

  for (const auto& e : edges) {
    double rot, trans, log_scale;
    EdgeErrors(e, result.world_from_node, &rot, &trans, &log_scale);
    result.edge_rotation_error_deg.push_back(rot);
    result.edge_translation_error.push_back(trans);
    result.edge_log_scale_error.push_back(log_scale);
    result.edge_inlier.push_back(result.connected[e.i] && result.connected[e.j] &&
                                 EdgeIsInlier(rot, trans, log_scale, options));
  }
  return result;
}

PoseGraphResult OptimizePoseGraphWithoutOutliers(int num_nodes, const std::vector<PoseGraphEdge>& edges,
                                                 const PoseGraphOptions& options, std::vector<bool>* dropped) {
  dropped->assign(edges.size(), false);
  for (;;) {
    std::vector<PoseGraphEdge> kept;
    std::vector<size_t> index;  // into edges
    for (size_t k = 0; k < edges.size(); ++k) {
      if ((*dropped)[k]) continue;
      kept.push_back(edges[k]);
      index.push_back(k);
    }
    PoseGraphResult r = OptimizePoseGraph(num_nodes, kept, options);
    int worst = -1;
    double worst_excess = 1;  // error over its threshold; > 1 is an outlier
    for (size_t m = 0; m < kept.size(); ++m) {
      if (!r.connected[kept[m].i] || !r.connected[kept[m].j]) continue;  // not in the solve at all
      const double excess = std::max({r.edge_rotation_error_deg[m] / options.max_rotation_error_deg,
                                      r.edge_translation_error[m] / options.max_translation_error,
                                      r.edge_log_scale_error[m] / options.max_log_scale_error});
      if (excess > worst_excess) {
        worst_excess = excess;
        worst = static_cast<int>(m);
      }
    }
    if (worst >= 0) {
      (*dropped)[index[worst]] = true;
      continue;
    }
    // Per-edge figures for every input edge, against the final poses.
    r.edge_rotation_error_deg.clear();
    r.edge_translation_error.clear();
    r.edge_log_scale_error.clear();
    r.edge_inlier.clear();
    for (size_t k = 0; k < edges.size(); ++k) {
      PoseGraphEdge e = edges[k];
      if (!options.estimate_scale) e.j_from_i.scale = 1.0;
      double rot, trans, log_scale;
      EdgeErrors(e, r.world_from_node, &rot, &trans, &log_scale);
      r.edge_rotation_error_deg.push_back(rot);
      r.edge_translation_error.push_back(trans);
      r.edge_log_scale_error.push_back(log_scale);
      r.edge_inlier.push_back(!(*dropped)[k] && r.connected[e.i] && r.connected[e.j] &&
                              EdgeIsInlier(rot, trans, log_scale, options));
    }
    return r;
  }
}

}  // namespace nerfreg
