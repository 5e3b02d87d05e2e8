#pragma once
// Closed-form alignment of corresponding point sets: weighted Umeyama / Kabsch.
#include <Eigen/Core>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct AlignmentOptions {
  bool estimate_scale = false;      // Sim(3) (Umeyama) vs SE(3) (Kabsch)
  double min_total_weight = 1e-12;  // below this the weights are degenerate
  void Check() const;
};

// Finds tgt_from_src minimising sum_i w_i |tgt_i - T * src_i|^2.
// src, tgt: [3, N] corresponding points; weights: [N] (non-negative) or empty for all ones.
// Returns false (expected failure, no exception) when fewer than 3 points carry weight, the
// weights sum to ~0, or the points are collinear/degenerate; the reflection case is fixed so
// the result is always a proper rotation.
bool EstimateSim3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Eigen::VectorXd& weights,
                   const AlignmentOptions& options, Sim3d* tgt_from_src);

// RANSAC over weighted correspondences, for matches of which many are wrong (a learned
// matcher's; DReg-NeRF's weighted Kabsch over all of them is pulled away from the truth by every
// outlier). Hypotheses come from 3 correspondences drawn in proportion to their weight; a
// hypothesis scores the weight of the correspondences it moves within inlier_radius (truncated:
// sum w_i (1 - d_i^2 / r^2)), and the best is refined by weighted Kabsch / Umeyama on its inliers,
// re-scored, refine_iterations times.
struct RobustAlignmentOptions {
  bool estimate_scale = false;
  double inlier_radius = 0.1;  // in the units of the points
  int iterations = 2000;       // hypotheses drawn
  int refine_iterations = 3;
  unsigned seed = 0;   // the draws are deterministic given the seed
  void Check() const;  // throws std::invalid_argument naming the field
};

struct RobustAlignmentResult {
  Sim3d tgt_from_src;
  double inlier_weight_fraction = 0;  // weight within inlier_radius of the result / total weight
  int inliers = 0;
  bool valid = false;  // false: fewer than 3 weighted points or no non-degenerate hypothesis
};

// src, tgt: [3, N]; weights: [N] >= 0 or empty for all ones. Throws std::invalid_argument on
// mismatched sizes.
RobustAlignmentResult EstimateSim3dRansac(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                                          const Eigen::VectorXd& weights, const RobustAlignmentOptions& options);

// Convenience: rigid (Kabsch) alignment.
bool EstimateRigid3d(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Eigen::VectorXd& weights,
                     Rigid3d* tgt_from_src);

}  // namespace nerfreg
