#pragma once
// Rotation averaging: global camera orientations from the view graph's relative rotations.
//
// Initialised by chaining relative rotations along a spanning tree that prefers edges with many
// inliers confirmed by many consistent triangles, then refined
// by Ceres over all edges: residual = the angle-axis vector of R_ij^T * R_j * R_i^T (radians),
// weighted by sqrt(inliers / median inliers), under a Cauchy loss so that a few wrong essential
// matrices (repeated texture, near-pure rotation) do not bend the others. The orientation of the
// root (the lowest-index image of the largest connected component) is held fixed: the gauge.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {

struct RotationAveragingOptions {
  double loss_scale_deg = 2.0;  // Cauchy scale on the residual angle, degrees
  int max_iterations = 100;     // Ceres iterations
  // Edges whose final residual exceeds this (degrees) are reported as outliers (edge_inlier).
  double max_edge_error_deg = 5.0;
  void Check() const;  // throws std::invalid_argument
};

struct RotationAveragingResult {
  // cam_from_world rotation of each image; identity for images outside the largest component.
  std::vector<Eigen::Quaterniond> cam_from_world;
  std::vector<bool> connected;  // in the largest connected component of the graph
  int root = -1;                // the image whose orientation is fixed (identity)
  // Per graph edge: residual angle after optimisation (degrees, 180 when not connected) and
  // whether it is below max_edge_error_deg.
  std::vector<double> edge_error_deg;
  std::vector<bool> edge_inlier;
};

// The largest connected component of the graph's edges (ties: the one with the lowest image).
std::vector<bool> LargestComponent(int num_images, const std::vector<ViewGraphEdge>& edges);

// Per graph edge: the number of third images m for which the loop i -> m -> j agrees with the
// edge's rotation within max_error_deg (wrong edges have little support).
std::vector<int> TriangleSupport(const ViewGraph& graph, double max_error_deg);

RotationAveragingResult AverageRotations(const ViewGraph& graph, const RotationAveragingOptions& options);

}  // namespace nerfreg
