// Voxel-grid averaging of keypoints and their features (DReg-NeRF spec 4, "Downsampling"):
// positions and features are averaged per cubic cell; a cascade of growing cell sizes is tried
// until source + target together fit a point budget. The output is sorted by voxel key
// (lexicographic x, y, z cell index), so it is deterministic and independent of the input order
// (the original's order was not, spec 9.6). Features stay differentiable (a mean per cell).
#pragma once

#include <torch/torch.h>

#include <vector>

namespace nerfreg {

struct VoxelDownsampleOptions {
  // Cell sizes tried in order (scene units) until the budget is met; the last one is used if none
  // meets it.
  std::vector<double> voxel_sizes = {0.05, 0.1, 0.2, 0.4, 0.8, 1.6};
  // Maximum number of source + target points together (paper: 3000, ~1500 per cloud).
  int64_t max_total_points = 3000;

  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

struct DownsampledCloud {
  torch::Tensor xyz;       // [M, 3], the input dtype; mean position per occupied cell.
  torch::Tensor features;  // [M, C], the input dtype; mean feature per occupied cell.
};

// xyz: [N, 3] float32/float64; features: [N, C] floating, same device, N >= 0.
// One cell size; output sorted by cell key.
DownsampledCloud VoxelAverage(const torch::Tensor& xyz, const torch::Tensor& features, double voxel_size);

struct DownsampledPair {
  DownsampledCloud src;
  DownsampledCloud tgt;
  // The cell size used; 0 when the inputs already fit the budget (returned unchanged).
  double voxel_size = 0.0;
};

// The cascade over both clouds at once (same cell size for both).
DownsampledPair VoxelDownsamplePair(const torch::Tensor& src_xyz, const torch::Tensor& src_features,
                                    const torch::Tensor& tgt_xyz, const torch::Tensor& tgt_features,
                                    const VoxelDownsampleOptions& options = {});

}  // namespace nerfreg
