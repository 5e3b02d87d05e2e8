#include "nerfreg/nerf/splat_export.h"

#include <algorithm>
#include <cmath>

#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/util/error.h"

namespace nerfreg {

void BlockSplatOptions::Check() const {
  if (!(min_density >= 0)) ThrowInputError("--density", "", ">= 0");
}

Splats BlockToSplats(NerfBlock& block, const BlockSplatOptions& options) {
  options.Check();
  constexpr double kC0 = 0.28209479177387814;
  const BlockPoints points = ExtractOccupiedPoints(block, options.min_density, options.seed);
  const auto xyz = points.xyz.to(torch::kCPU).contiguous(), rgb = points.rgb.to(torch::kCPU).clamp(0, 1).contiguous();
  const auto sigma = points.sigma.to(torch::kCPU).to(torch::kDouble).contiguous();
  const std::int64_t n = xyz.size(0);
  // The occupancy grid's cell in the block's frame.
  const double cell = (block.field_options.aabb_max[0] - block.field_options.aabb_min[0]) / block.grid->resolution() *
                      block.world_from_field.scale;
  const float log_scale = static_cast<float>(std::log(0.5 * cell));
  Splats s;
  s.Resize(n, 0, /*normals=*/false);
  const float* p = xyz.data_ptr<float>();
  const float* c = rgb.data_ptr<float>();
  const double* sg = sigma.data_ptr<double>();
  for (std::int64_t i = 0; i < n; ++i) {
    s.position.col(i) = Eigen::Vector3f(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    for (int k = 0; k < 3; ++k) s.f_dc(k, i) = static_cast<float>((c[3 * i + k] - 0.5) / kC0);
    const double alpha = std::clamp(1.0 - std::exp(-sg[i] * cell), 0.01, 0.99);
    s.opacity(i) = static_cast<float>(std::log(alpha / (1 - alpha)));
    s.log_scale.col(i).setConstant(log_scale);
    s.rotation.col(i) = Eigen::Vector4f(1, 0, 0, 0);
  }
  return s;
}

}  // namespace nerfreg
