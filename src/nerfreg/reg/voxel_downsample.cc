#include "nerfreg/reg/voxel_downsample.h"

#include "nerfreg/util/logging.h"

namespace nerfreg {

bool VoxelDownsampleOptions::Check() const {
  if (voxel_sizes.empty()) {
    LOG_ERROR("VoxelDownsampleOptions.voxel_sizes is empty");
    return false;
  }
  for (double v : voxel_sizes) {
    if (!(v > 0.0)) {
      LOG_ERROR("VoxelDownsampleOptions.voxel_sizes must be > 0, got {}", v);
      return false;
    }
  }
  if (max_total_points < 2) {
    LOG_ERROR("VoxelDownsampleOptions.max_total_points must be >= 2, got {}", max_total_points);
    return false;
  }
  return true;
}

DownsampledCloud VoxelAverage(const torch::Tensor& xyz, const torch::Tensor& features, double voxel_size) {
  TORCH_CHECK(xyz.dim() == 2 && xyz.size(1) == 3, "VoxelAverage: xyz must be [N,3], got ", xyz.sizes());
  TORCH_CHECK(xyz.is_floating_point(), "VoxelAverage: xyz must be floating point");
  TORCH_CHECK(features.dim() == 2 && features.size(0) == xyz.size(0),
              "VoxelAverage: features must be [N,C] with N = ", xyz.size(0), ", got ", features.sizes());
  TORCH_CHECK(features.is_floating_point(), "VoxelAverage: features must be floating point");
  TORCH_CHECK(voxel_size > 0.0, "VoxelAverage: voxel_size must be > 0");
  if (xyz.size(0) == 0) return {xyz, features};

  const torch::Tensor cell = torch::floor(xyz.detach().to(torch::kDouble) / voxel_size).to(torch::kLong);  // [N,3]
  const torch::Tensor rel = cell - std::get<0>(cell.min(0, true));                                         // [N,3] >= 0
  const torch::Tensor extent = std::get<0>(rel.max(0)) + 1;                                                // [3]
  const int64_t ny = extent[1].item<int64_t>(), nz = extent[2].item<int64_t>();
  const torch::Tensor key = (rel.select(1, 0) * ny + rel.select(1, 1)) * nz + rel.select(1, 2);
  auto [unique_keys, inverse, counts] =
      at::_unique2(key, /*sorted=*/true, /*return_inverse=*/true, /*return_counts=*/true);
  const int64_t m = unique_keys.size(0);
  const torch::Tensor denom = counts.to(xyz.scalar_type()).unsqueeze(1);  // [M,1]
  DownsampledCloud out;
  out.xyz = torch::zeros({m, 3}, xyz.options()).index_add(0, inverse, xyz) / denom;
  out.features = torch::zeros({m, features.size(1)}, features.options()).index_add(0, inverse, features) /
                 denom.to(features.scalar_type());
  return out;
}

DownsampledPair VoxelDownsamplePair(const torch::Tensor& src_xyz, const torch::Tensor& src_features,
                                    const torch::Tensor& tgt_xyz, const torch::Tensor& tgt_features,
                                    const VoxelDownsampleOptions& options) {
  TORCH_CHECK(options.Check(), "VoxelDownsamplePair: invalid options");
  DownsampledPair out;
  out.src = {src_xyz, src_features};
  out.tgt = {tgt_xyz, tgt_features};
  if (src_xyz.size(0) + tgt_xyz.size(0) <= options.max_total_points) return out;
  for (double voxel_size : options.voxel_sizes) {
    out.src = VoxelAverage(src_xyz, src_features, voxel_size);
    out.tgt = VoxelAverage(tgt_xyz, tgt_features, voxel_size);
    out.voxel_size = voxel_size;
    if (out.src.xyz.size(0) + out.tgt.xyz.size(0) <= options.max_total_points) return out;
  }
  LOG_WARN("VoxelDownsamplePair: {} + {} points exceed the budget {} at the largest cell {}", out.src.xyz.size(0),
           out.tgt.xyz.size(0), options.max_total_points, out.voxel_size);
  return out;
}

}  // namespace nerfreg
