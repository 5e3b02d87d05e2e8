#include "nerfreg/reg/grid_extraction.h"

#include "nerfreg/util/error.h"

namespace nerfreg {

void GridExtractionOptions::Check() const {
  if (resolution < 8 || resolution > 512) ThrowInputError("--grid-resolution", "", "8..512");
  if (!(side > 0)) ThrowInputError("--grid-side", "", "> 0");
  if (!(min_density >= 0)) ThrowInputError("--min-density", "", ">= 0");
  if (samples_per_voxel < 1 || samples_per_voxel > 64) ThrowInputError("--samples-per-voxel", "", "1..64");
  if (variant != "surface" && variant != "df") ThrowInputError("--variant", "", "surface or df");
  try {
    ResolvedSurface().Check();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("surface field options: ") + e.what());
  }
}

SurfaceFieldOptions GridExtractionOptions::ResolvedSurface() const {
  SurfaceFieldOptions s = surface;
  if (s.mode == "window" && !(s.window > 0) && resolution > 0) s.window = side / resolution;
  return s;
}

RegGrid ExtractRegGridFromField(const GridFieldQueries& field, const Eigen::Vector3d& centre,
                                const GridExtractionOptions& options) {
  options.Check();
  torch::NoGradGuard no_grad;
  const int d = options.resolution;
  RegGrid g;
  g.source = field.source;
  g.variant = options.variant;
  g.aabb_min = centre - Eigen::Vector3d::Constant(0.5 * options.side);
  g.aabb_max = centre + Eigen::Vector3d::Constant(0.5 * options.side);
  const float cell = static_cast<float>(options.side / d);

  torch::Generator gen = at::detail::createCPUGenerator(options.seed);
  const auto idx = torch::arange(d, torch::kFloat32);
  const auto ijk = torch::meshgrid({idx, idx, idx}, "ij");
  const auto mn = torch::tensor({float(g.aabb_min.x()), float(g.aabb_min.y()), float(g.aabb_min.z())});
  const auto corner = mn + torch::stack({ijk[0], ijk[1], ijk[2]}, -1).reshape({-1, 3}) * cell;  // [D^3, 3]
  // k jittered samples per voxel; the densest is the voxel's point.
  const int k = options.samples_per_voxel;
  const auto cand = corner.unsqueeze(1) + torch::rand({d * d * d, k, 3}, gen) * cell;       // [D^3, k, 3]
  const auto cand_sigma = field.density(cand.reshape({-1, 3})).view({d * d * d, k});        // [D^3, k]
  const auto best = cand_sigma.argmax(1);                                                   // [D^3]
  const auto points = cand.gather(1, best.view({-1, 1, 1}).expand({-1, 1, 3})).squeeze(1);  // [D^3, 3]
  const auto sigma = cand_sigma.gather(1, best.view({-1, 1})).squeeze(1);                   // [D^3]
  g.xyz = points.reshape({d, d, d, 3}).contiguous();
  const auto dense = sigma > options.min_density;  // [D^3]
  const auto dense_idx = dense.nonzero().squeeze(1);
  const auto dense_pts = points.index_select(0, dense_idx);

  // Colour (view-averaged) at the dense points only.
  const auto rgb = field.color(dense_pts);
  auto rgba = torch::zeros({d * d * d, 4});
  rgba.index_copy_(
      0, dense_idx,
      torch::cat({rgb, (1 - torch::exp(-0.01 * sigma.index_select(0, dense_idx))).clamp(0, 1).unsqueeze(1)}, 1));
  g.rgba = rgba.t().reshape({4, d, d, d}).contiguous();

  auto surface = torch::zeros({d * d * d});
  if (dense_pts.size(0) > 0) {
    surface.index_copy_(0, dense_idx, field.surface ? field.surface(dense_pts) : torch::ones({dense_pts.size(0)}));
  }
  g.surface = surface.reshape({d, d, d});
  g.mask = options.variant == "df" ? dense.reshape({d, d, d})
                                   : (dense & (surface >= options.surface_threshold)).reshape({d, d, d});
  g.Check();
  return g;
}

RegGrid ExtractRegGrid(NerfBlock& block, const GridExtractionOptions& options) {
  const auto& fmin = block.field_options.aabb_min;
  const auto& fmax = block.field_options.aabb_max;
  // The field box's centre in the block's frame (a moved block's box is rotated there).
  const Eigen::Vector3d centre =
      block.world_from_field *
      Eigen::Vector3d(0.5 * (fmin[0] + fmax[0]), 0.5 * (fmin[1] + fmax[1]), 0.5 * (fmin[2] + fmax[2]));
  GridFieldQueries q;
  q.source = "nerf";
  q.density = [&block](const torch::Tensor& x) { return QueryDensity(block, x); };
  q.color = [&block](const torch::Tensor& x) { return ViewAveragedColor(block, x); };
  const SurfaceFieldOptions surface = options.ResolvedSurface();
  q.surface = [&block, surface](const torch::Tensor& x) {
    if (block.cameras.IndicesOfSplit("train").empty()) {
      ThrowInputError("block", "cameras", "training cameras in the checkpoint (the surface field marches from them)");
    }
    return SurfaceField(block, x, surface);
  };
  return ExtractRegGridFromField(q, centre, options);
}

}  // namespace nerfreg
