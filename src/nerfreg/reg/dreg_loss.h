// The DReg-NeRF training loss (spec dreg-nerf.md 5) with the original's bugs fixed (spec 9.1-9.4).
// Applied to every transformer layer's output and summed over layers (REGTR supervises all
// layers); with all_layers = false only the last layer counts. Per layer, with S the surface
// label of each keypoint, T = target_from_source (ground truth):
//
//  confidence      BCE(input = predicted confidence, target = S), both clouds, mean over points
//                  (computed from the logits for stability). The original swapped input and target
//                  (9.1), which gives no signal where S = 0.
//  surface         Surface-field consistency: a match of a surface point should lie on the other
//                  block's surface. S_other(corr) is the OTHER grid's surface volume sampled
//                  trilinearly (torch::grid_sample, zero outside its box) at the predicted
//                  correspondence, which lives in the other block's frame; the term is
//                  mean_i (S_other(corr_i) - S_i)^2 over both clouds. Differentiable in the
//                  correspondences (the original thresholded with no gradient and evaluated
//                  target-frame points in the source NeRF, 9.2).
//  correspondence  Barron robust loss per coordinate of (corr_i - T x_i) (source keypoints; the
//                  target ones against T^-1 y_j), summed over xyz, then an S-weighted mean over
//                  both clouds stacked: sum_i S_i rho_i / sum_i S_i (9.3: the original broadcast
//                  this into an unweighted sum). rho(x) = |a-2|/a (((x/c)^2/|a-2| + 1)^(a/2) - 1);
//                  alpha = 1 gives sqrt((x/c)^2 + 1) - 1.
//  feature         InfoNCE both ways with the bilinear similarity f_s^T W f_t, W = the model's
//                  trainable DregOutput::feature_w symmetrised (9.4). The positive of source
//                  keypoint i is the target keypoint nearest to T x_i if closer than r_p (else i is
//                  skipped); target keypoints within r_n of T x_i other than the positive are
//                  left out of the denominator; the rest are negatives. Mean over anchors.
//
// overlap_labels (ours, off by default as in the paper): S alone says "a surface was seen here",
// not "the other block saw it too". For blocks that overlap little (adjacent blocks of a 4-block
// split overlap ~50-80 %), the paper's labels ask every surface keypoint for a match and a high
// confidence, including the ones whose true match lies where the other block saw nothing; the
// confidences then weight Procrustes towards points that cannot match. With overlap_labels each
// label becomes S_i * O_i, O_i = the other block's surface field, dilated by one voxel (3^3 max)
// and sampled at the keypoint's true position in its frame (SampleSeenSurface): the confidence
// learns the overlap (as Predator's / REGTR's overlap scores), the correspondence loss is weighted
// by it, and the surface term is an O-weighted mean (a point the other block did not see has no
// surface to land on there).
#pragma once

#include <torch/torch.h>

#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/reg_grid.h"

namespace nerfreg {

struct DregLossOptions {
  // Term weights (the original's code).
  double confidence_weight = 1.0;
  double surface_weight = 1.0;
  double feature_weight = 0.1;
  double correspondence_weight = 1.0;
  // InfoNCE positive radius and negative radius, scene units (r_p <= r_n).
  double positive_radius = 0.2;
  double negative_radius = 0.4;
  // Barron robust loss shape alpha (any real; 0 and 2 are the limits) and scale c > 0.
  double barron_alpha = 1.0;
  double barron_c = 0.5;
  // Supervise every layer (summed) or only the last.
  bool all_layers = true;
  // Labels S * O (see the top of this file); false: S (the paper).
  bool overlap_labels = false;

  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

// Each term is a [] float32 tensor, already summed over the supervised layers and NOT multiplied
// by its weight; total = sum of weight * term.
struct DregLossTerms {
  torch::Tensor total;
  torch::Tensor confidence;
  torch::Tensor surface;
  torch::Tensor correspondence;
  torch::Tensor feature;
};

// out: a forward pass of DregNet on (src, tgt); src, tgt: the same grids (their surface volumes
// and boxes are read); target_from_source: [4, 4] float32 ground truth (top-left may hold s R).
DregLossTerms DregLoss(const DregOutput& out, const RegGrid& src, const RegGrid& tgt,
                       const torch::Tensor& target_from_source, const DregLossOptions& options = {});

// The building blocks, exposed for tests and for evaluation code.
// x: any shape; returns rho(x) elementwise (see above).
torch::Tensor BarronLoss(const torch::Tensor& x, double alpha, double c);
// Trilinear sample of grid.surface ([D, D, D]) at points [N, 3] in the grid's frame -> [N];
// zero outside the box; differentiable in the points.
torch::Tensor SampleSurface(const RegGrid& grid, const torch::Tensor& points);
// The same on grid.surface dilated by one voxel (max over each voxel's 3^3 neighbourhood): how much
// the block saw a surface at or next to each point, in [0, 1]; the overlap O above. No gradient.
torch::Tensor SampleSeenSurface(const RegGrid& grid, const torch::Tensor& points);

}  // namespace nerfreg
