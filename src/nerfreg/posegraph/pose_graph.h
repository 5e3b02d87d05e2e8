#pragma once
// Fusing pairwise relative poses into one consistent set of absolute poses (a pose graph), used
// for registering many NeRF blocks or splat captures into one scene (`reg register-many`). The
// poses are similarities: captures made separately do not share a unit, so each node has a
// rotation, a translation and a log-scale (with PoseGraphOptions::estimate_scale false every scale
// stays 1: a rigid graph). Ceres with a robust loss, so a few wrong pairwise registrations do not
// drag the whole graph; initialised by a maximum-weight spanning tree; node 0 fixes the gauge
// (its pose is the identity, its scale 1).
#include <vector>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

// A measured relative pose between nodes i and j: x_in_j = j_from_i * x_in_i.
struct PoseGraphEdge {
  int i = 0;
  int j = 0;
  Sim3d j_from_i;       // its scale is ignored (taken as 1) when the graph is rigid
  double weight = 1.0;  // confidence (e.g. registration confidence or inlier count), > 0
};

struct PoseGraphOptions {
  // Whether the nodes' scales are optimised (a Sim(3) graph). False: a rigid graph, every scale 1
  // and the edges' scales ignored (inputs that share a unit).
  bool estimate_scale = true;
  // Cauchy loss scale on each edge's (weighted) residual norm; residuals are radians for the
  // rotation part, world (node 0) units for the translation part (where node i's origin lands
  // through the edge against through its own pose) and natural log of the scale ratio for the
  // scale part.
  double loss_scale = 0.1;
  // Relative weight of the translation residual against the rotation residual.
  double translation_weight = 1.0;
  // Relative weight of the log-scale residual against the rotation residual.
  double scale_weight = 1.0;
  int max_iterations = 200;
  // Edges whose final rotation error exceeds this (degrees), translation error exceeds
  // max_translation_error (world units) or log-scale error exceeds max_log_scale_error are
  // reported as outliers.
  double max_rotation_error_deg = 5.0;
  double max_translation_error = 0.1;
  double max_log_scale_error = 0.05;
  void Check() const;  // throws std::invalid_argument
};

struct PoseGraphResult {
  // world_from_node for every node; node 0 defines the world frame (identity). Nodes not
  // connected to node 0 keep identity and have connected[k] == false.
  std::vector<Sim3d> world_from_node;
  std::vector<bool> connected;
  // Per edge, after optimisation: rotation error (deg), translation error (world units) and
  // |log| of the scale ratio of the measurement against the fused poses, and whether it is an
  // inlier by the options' thresholds.
  std::vector<double> edge_rotation_error_deg;
  std::vector<double> edge_translation_error;
  std::vector<double> edge_log_scale_error;
  std::vector<bool> edge_inlier;
  double initial_cost = 0;
  double final_cost = 0;
  bool converged = false;
};

// For each edge, the number of nodes m for which going i -> m -> j agrees with the edge within
// the given thresholds (cycle consistency; translation in node j's units, scale as |log| of the
// ratio): wrong registrations have little support.
std::vector<double> TriangleSupport(int num_nodes, const std::vector<PoseGraphEdge>& edges, double max_rotation_deg,
                                    double max_translation, double max_log_scale = 0.15);

// Initial absolute poses from a maximum-priority spanning tree rooted at node 0, priority =
// weight * (1 + triangle support).
std::vector<Sim3d> InitializeFromSpanningTree(int num_nodes, const std::vector<PoseGraphEdge>& edges,
                                              std::vector<bool>* connected);

// Optimises the graph. Throws std::invalid_argument on edges naming unknown nodes, self-loops or
// non-positive weights.
PoseGraphResult OptimizePoseGraph(int num_nodes, const std::vector<PoseGraphEdge>& edges,
                                  const PoseGraphOptions& options);

// OptimizePoseGraph, then, while some edge disagrees with the fused poses (its loop), drops the
// edge that disagrees most and solves again: a wrong registration in a loop pulls its neighbours
// off too, so one solve's outlier flags are not enough to trust what remains. On return,
// (*dropped)[k] tells whether edges[k] was dropped; the result's per-edge arrays cover every input
// edge (a dropped edge is never an inlier; its errors are against the final poses).
PoseGraphResult OptimizePoseGraphWithoutOutliers(int num_nodes, const std::vector<PoseGraphEdge>& edges,
                                                 const PoseGraphOptions& options, std::vector<bool>* dropped);

}  // namespace nerfreg
