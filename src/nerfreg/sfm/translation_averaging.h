#pragma once
// Translation averaging: global camera centres from the view graph's unit translation directions
// once the orientations are known (rotation_averaging.h).
//
// An edge i -> j with x_in_j = R_ij x_in_i + t_ij (|t_ij| = 1) says that c_j - c_i is parallel to
// d_ij = -R_j^T t_ij (world frame), with an unknown positive length. Two steps:
//  1. Linear: minimise sum_ij w_ij |d_ij x (c_j - c_i)|^2 over unit-norm centres with c_root = 0
//     (the smallest eigenvector of a 3(n-1) x 3(n-1) normal matrix; the sign is chosen so that
//     most edges point the measured way), reweighted a few times by a Cauchy weight on each
//     edge's angle, so wrong directions lose their say.
//  2. Nonlinear (Ceres): residual (c_j - c_i) / |c_j - c_i| - d_ij with a Huber loss, c_root held
//     fixed and, since the residual is scale-free, the largest coordinate of the farthest centre
//     too. Finally the scale is set: the mean distance of the other cameras to the root is 1.
// The cross product alone (step 1) prefers short baselines and has no notion of direction; the
// normalised residual (step 2, as in 1DSfM / Theia) weighs every edge's angle alike.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {

struct TranslationAveragingOptions {
  int reweighting_rounds = 3;        // linear solves, each reweighting edges by their angle error
  double cauchy_scale_deg = 5.0;     // angle scale of those weights, degrees
  double huber_scale = 0.05;         // Huber scale of the nonlinear residual (unit vectors; ~3 deg)
  int max_iterations = 100;          // Ceres iterations of the nonlinear step
  double max_edge_error_deg = 15.0;  // edges whose final angle exceeds this are outliers
  void Check() const;                // throws std::invalid_argument
};

struct TranslationAveragingResult {
  std::vector<Eigen::Vector3d> centers;  // world frame; zero for images not solved
  std::vector<bool> solved;              // the largest component of the usable edges, >= 2 images
  int root = -1;                         // the centre held at the origin
  std::vector<double> edge_error_deg;    // per graph edge: angle between c_j - c_i and d_ij (180: unused)
  std::vector<bool> edge_inlier;
};

// cam_from_world: one orientation per image; usable: one flag per graph edge (empty: all).
TranslationAveragingResult AverageTranslations(const ViewGraph& graph,
                                               const std::vector<Eigen::Quaterniond>& cam_from_world,
                                               const std::vector<bool>& usable,
                                               const TranslationAveragingOptions& options);

}  // namespace nerfreg
