// Differentiable weighted Kabsch / Umeyama in LibTorch: the pose solver of DReg-NeRF (spec 4,
// "Pose"). Given correspondences x_in_src[i] <-> x_in_tgt[i] with non-negative weights w[i], finds
//   argmin_{s,R,t} sum_i w_i |x_in_tgt[i] - (s R x_in_src[i] + t)|^2,   R in SO(3), s > 0,
// so that x_in_tgt = s * R * x_in_src + t (tgt_from_src). Gradients flow to points and weights.
//
// Degenerate input (total weight ~0) is an expected outcome, not an error: that batch element
// returns identity, scale 1 and valid = false, and all gradients stay finite (zero for it).
// Rank-deficient covariances (collinear points, weight on <= 2 points) have repeated singular
// values, where the SVD gradient is undefined (its backward divides by the differences of their
// squares); a tiny, distinct diagonal regulariser keeps them apart so the gradient is finite.
#pragma once

#include <torch/torch.h>

namespace nerfreg {

struct WeightedProcrustesOptions {
  // Also solve an isotropic scale s (Sim(3)); otherwise s = 1 (SE(3), the paper's setting).
  bool estimate_scale = false;
  // A batch element whose weights sum to less than this is degenerate (identity, valid = false).
  double min_weight_sum = 1e-6;
  // Regulariser added to the 3x3 cross-covariance as regularizer * diag(3, 2, 1) * (1 + |H|) so
  // that its singular values are distinct (finite SVD gradient). Relative to normalised weights.
  double regularizer = 1e-7;

  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

struct WeightedProcrustesResult {
  // tgt_from_src rotation, [B, 3, 3] (or [3, 3] for unbatched input), input dtype; det = +1.
  torch::Tensor rotation;
  // tgt_from_src translation, [B, 3] (or [3]).
  torch::Tensor translation;
  // Scale, [B] (or []); exactly 1 unless options.estimate_scale.
  torch::Tensor scale;
  // Whether the element was solvable, [B] (or []) bool; false -> identity, zero gradient.
  torch::Tensor valid;
};

// x_in_src, x_in_tgt: [B, N, 3] or [N, 3], float32 or float64, same device; weights: [B, N] or [N],
// same dtype, >= 0 (need not be normalised: they are divided by their sum). N >= 1.
// Throws (c10::Error) on shape/dtype mismatch.
WeightedProcrustesResult WeightedProcrustes(const torch::Tensor& x_in_src, const torch::Tensor& x_in_tgt,
                                            const torch::Tensor& weights,
                                            const WeightedProcrustesOptions& options = {});

}  // namespace nerfreg
