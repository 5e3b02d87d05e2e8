#pragma once
// Closed-form alignment of corresponding point sets: weighted Umeyama / Kabsch.
#include <Eigen/Core>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct AlignmentOptions {
  bool estimate_scale = false;  // Sim(3) (Umeyama) vs SE(3) (Kabsch)
  double min_total_weight = 1e-12;  // below this the weights are degenerate
  void Check() const;
};

// Finds tgt_from_src minimising sum_i w_i |tgt_i - T * src_i|^2.
// src, tgt: [3, N] corresponding points; weights: [N] (non-negative) or empty for all ones.
// Returns false (expected failure, no exception) when fewer than 3 points carry weight, the
// weights sum to ~0, or the points are collinear/degenerate; the reflection case is fixed so
// the result is always a proper rotation.
bool EstimateSim3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                   const Eigen::VectorXd& weights, const AlignmentOptions& options,
                   Sim3d* tgt_from_src);

// Convenience: rigid (Kabsch) alignment.
bool EstimateRigid3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                     const Eigen::VectorXd& weights, Rigid3d* tgt_from_src);

}  // namespace nerfreg
