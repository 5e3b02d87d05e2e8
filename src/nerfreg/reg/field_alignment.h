#pragma once
// Fine registration of two NeRF blocks on their density fields: the last step after a coarse
// pose (DReg-NeRF or FPFH + RANSAC, then ICP).
//
// Why: ICP on the extracted grids cannot get below the grids' quantisation: started AT the true
// pose it drifts away (the points are one jittered sample per 0.11-unit cell at D = 32;
// docs/notes/2026-11-23-grids-icp-half-turn.md); the fields themselves are continuous and
// agree more closely than their grids.
//
// What: with occupancy o(x) = 1 - exp(-occupancy_scale * sigma(x)), find target_from_source T
// minimising, over samples y near the source's surface and x near the target's,
//   sum_y (o_tgt(T y) - o_src(y))^2 + sum_x (o_src(T^-1 x) - o_tgt(x))^2
// by Levenberg-Marquardt on a left SE(3) increment. Spatial gradients of o are central finite
// differences (the hash encoding's fused kernel gives no position gradients), so one iteration
// costs 7 density queries per sample. A sample whose image falls outside the other field's box
// carries no weight: outside it that block knows nothing, which is not the same as empty.
// Symmetric, so neither block's floaters or unseen regions dominate.
//
// The basin is a few degrees (measured from 1.5 and 3 deg starts); it refines, it does not search.
//
// Overlap only (FieldAlignmentOptions::overlap_only): a block knows nothing of what its cameras
// did not see, though its box holds it (a NeRF leaves unseen surfaces empty or fills them with
// floaters). With `seen` set on both fields, a sample counts only where the other block saw the
// surface too, judged once at the start pose: between adjacent blocks of a 4-block split half the
// samples can fall where the other block never looked.
#include <torch/torch.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <random>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/reg_grid.h"

namespace nerfreg {

struct NerfBlock;

// A density field: positions [N, 3] float32 (its frame) -> sigma [N]; `box` is where it is known.
struct DensityField {
  std::function<torch::Tensor(const torch::Tensor&)> density;
  Eigen::AlignedBox3d box;
  // Optional: positions [N, 3] float32 -> [N] bool, where the block's cameras saw a surface
  // (within a cell; e.g. SeenFromGrid). Empty: unknown.
  std::function<torch::Tensor(const torch::Tensor&)> seen;
};

// The block's field and its AABB.
DensityField BlockDensityField(NerfBlock& block);

// DensityField::seen from a block's registration grid: true within `dilation` cells of a masked
// voxel (the mask is the surface the block's cameras saw: density and S >= 0.5). One cell of
// dilation covers the band the samples are drawn in.
std::function<torch::Tensor(const torch::Tensor&)> SeenFromGrid(const RegGrid& grid, int dilation = 1);

struct FieldAlignmentOptions {
  // o = 1 - exp(-occupancy_scale * sigma). Larger: a sharper surface (more precise, smaller basin).
  // 0.05 had the best worst case of 0.02-1 on the tuning pairs (two real block pairs of training
  // meshes; docs/notes/2026-11-23-grids-icp-half-turn.md, "Field refinement tuning").
  double occupancy_scale = 0.05;
  // Samples: each surface point gives two, offset by Gaussian noise of 0.25 and 0.5 x sample_spread
  // (a band across the surface, where o changes); at most max_samples per block.
  double sample_spread = 0.11;  // scene units; the grid's cell
  int max_samples = 6000;
  double gradient_step = 0.25;  // finite-difference step, x sample_spread
  int iterations = 30;          // LM iterations at most (18-33 were used on the tuning pairs)
  double tolerance_deg = 1e-3;  // stop when an accepted step turns less than this (and moves < 1e-5)
  // Keep only samples the other block saw (at the start pose), when both fields have `seen` and
  // at least min_overlap_samples remain (else every sample, as without it).
  bool overlap_only = false;
  int min_overlap_samples = 200;
  // Also refine the scale (a seventh, log-scale increment): for inputs in different units, whose
  // scale the point stages estimated (registration's ScaleMode::kFree). Off: the scale is held.
  bool estimate_scale = false;
  unsigned seed = 0;
  void Check() const;  // throws InputError naming the option
};

struct FieldAlignmentResult {
  Rigid3d target_from_source;               // with `scale`: x_target = scale * R x_source + t
  double scale = 1.0;                       // the scale given, or refined (estimate_scale)
  double initial_cost = 0, final_cost = 0;  // mean squared occupancy difference over the samples inside the other box
  int iterations = 0;
  int samples = 0;  // with weight at the final pose
  // With overlap_only: the share of samples the other block saw (kept), or -1 when not applied.
  double overlap_fraction = -1;
  double seconds = 0;
};

// Samples in a band across a surface: two per point of `points` [3, N] (a random subset when
// there are more than max_samples / 2), offset by Gaussian noise of 0.25 and 0.5 x spread. What
// AlignFields samples, and what registration candidates are scored on (pipeline/register_blocks.h).
Eigen::Matrix3Xd SurfaceBandSamples(const Eigen::Matrix3Xd& points, double spread, int max_samples, std::mt19937& rng);

// source_points [3, Ns], target_points [3, Nt]: surface points in each block's frame (a grid's
// MaskedXyz). `scale` (a Sim(3) solve's) is held fixed unless options.estimate_scale:
// T y = scale * R y + t. A density is per unit length, so the source's is compared in target
// units (sigma / scale, at the scale given). Returns the
// initial pose unchanged (iterations 0) when fewer than 10 samples land in both boxes.
FieldAlignmentResult AlignFields(const DensityField& source, const DensityField& target,
                                 const Eigen::Matrix3Xd& source_points, const Eigen::Matrix3Xd& target_points,
                                 const Rigid3d& initial_target_from_source, const FieldAlignmentOptions& options,
                                 double scale = 1.0);

}  // namespace nerfreg
