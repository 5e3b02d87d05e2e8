#include "nerfreg/dbarf/photometric_bundle_adjustment.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "nerfreg/dbarf/inverse_warp.h"
#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/sfm_loss.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

void PhotometricBundleAdjustmentOptions::Check() const {
  if (levels < 1) throw InputError("photometric BA levels: expected >= 1, got " + std::to_string(levels));
  if (iterations_per_level < 0) throw InputError("photometric BA iterations: expected >= 0");
  if (!(pose_step > 0) || !(depth_step > 0)) throw InputError("photometric BA steps: expected > 0");
  if (depth_grid_stride < 1) throw InputError("photometric BA depth grid stride: expected >= 1");
  if (!(smoothness_weight >= 0)) throw InputError("photometric BA smoothness weight: expected >= 0");
  if (!(ssim_weight >= 0 && ssim_weight <= 1)) throw InputError("photometric BA SSIM weight: expected in [0, 1]");
}

namespace {

namespace F = torch::nn::functional;

struct Problem {
  torch::Tensor images;      // [V, 3, h, w]
  torch::Tensor intrinsics;  // [V, 3, 3]
  torch::Tensor inv_depths;  // [V, 1, h, w], initial
  torch::Tensor tgt, src;    // [E] long
  double clip_std_factor = 1.0;
  double ssim_weight = 0.85;
};

// Mean per-pixel error over the valid pixels of every pair (robustly clipped per pair);
// valid_fraction (optional): the share of the pairs' target pixels that warp inside the source.
torch::Tensor PhotometricTerm(const Problem& p, const torch::Tensor& cam_from_world, const torch::Tensor& grid,
                              double* valid_fraction = nullptr) {
  const int64_t h = p.images.size(2), w = p.images.size(3);
  const torch::Tensor correction = F::interpolate(
      grid, F::InterpolateFuncOptions().size(std::vector<int64_t>{h, w}).mode(torch::kBilinear).align_corners(false));
  const torch::Tensor inv_depths = p.inv_depths * torch::exp(correction);  // [V, 1, h, w]
  const torch::Tensor src_from_tgt =
      RelativeTransform(cam_from_world.index_select(0, p.src), cam_from_world.index_select(0, p.tgt));  // [E, 4, 4]
  const InverseWarpResult warp =
      InverseWarp(p.images.index_select(0, p.src), inv_depths.index_select(0, p.tgt), src_from_tgt,
                  p.intrinsics.index_select(0, p.tgt), p.intrinsics.index_select(0, p.src));
  torch::Tensor error =
      PhotometricErrorMap(warp.warped, p.images.index_select(0, p.tgt), p.ssim_weight);  // [E, 1, h, w]
  const torch::Tensor valid = warp.valid;                                                // [E, 1, h, w]
  const torch::Tensor count = valid.sum({1, 2, 3}).clamp_min(1.0);                       // [E]
  if (p.clip_std_factor >= 0) {
    const torch::Tensor e = error.detach();
    const torch::Tensor mean = (e * valid).sum({1, 2, 3}) / count;
    const torch::Tensor var = ((e - mean.view({-1, 1, 1, 1})).pow(2) * valid).sum({1, 2, 3}) / count;
    const torch::Tensor limit = (mean + p.clip_std_factor * var.sqrt()).view({-1, 1, 1, 1});
    error = torch::minimum(error, limit);
  }
  if (valid_fraction != nullptr) *valid_fraction = valid.mean().item<double>();
  return (error * valid).sum() / valid.sum().clamp_min(1.0);
}

torch::Tensor Smoothness(const torch::Tensor& grid) {
  torch::Tensor s = torch::zeros({}, grid.options());
  if (grid.size(2) > 1) s = s + (grid.slice(2, 1) - grid.slice(2, 0, -1)).pow(2).mean();
  if (grid.size(3) > 1) s = s + (grid.slice(3, 1) - grid.slice(3, 0, -1)).pow(2).mean();
  return s;
}

}  // namespace

PhotometricBundleAdjustmentResult PhotometricBundleAdjust(const torch::Tensor& images, const torch::Tensor& intrinsics,
                                                          const torch::Tensor& inv_depths,
                                                          const torch::Tensor& cam_from_world,
                                                          const std::vector<std::pair<int, int>>& pairs,
                                                          int fixed_camera,
                                                          const PhotometricBundleAdjustmentOptions& options) {
  options.Check();
  if (images.dim() != 4 || images.size(1) != 3)
    throw std::invalid_argument("PhotometricBundleAdjust: images must be [V, 3, H, W]");
  const int64_t v = images.size(0), height = images.size(2), width = images.size(3);
  if (intrinsics.sizes() != torch::IntArrayRef({v, 3, 3}) || cam_from_world.sizes() != torch::IntArrayRef({v, 4, 4}) ||
      inv_depths.sizes() != torch::IntArrayRef({v, 1, height, width})) {
    throw std::invalid_argument(
        "PhotometricBundleAdjust: intrinsics [V, 3, 3], cam_from_world [V, 4, 4], inv_depths [V, 1, H, W]");
  }
  if (fixed_camera < 0 || fixed_camera >= v)
    throw std::invalid_argument("PhotometricBundleAdjust: fixed_camera out of range");
  std::vector<int64_t> tgt, src;
  for (const auto& [t, s] : pairs) {
    if (t < 0 || s < 0 || t >= v || s >= v || t == s) throw std::invalid_argument("PhotometricBundleAdjust: bad pair");
    tgt.push_back(t), src.push_back(s);
  }
  const Timer timer;
  torch::NoGradGuard outer_no_grad;
  PhotometricBundleAdjustmentResult result;
  const torch::Tensor images32 = images.to(torch::kFloat), k32 = intrinsics.to(torch::kFloat);
  // The world scaled so that the median depth of the targets is 1.
  const torch::Tensor tgt_index = torch::tensor(tgt, torch::kLong), src_index = torch::tensor(src, torch::kLong);
  double median_depth = 1.0;
  if (!pairs.empty()) {
    median_depth =
        1.0 / std::get<0>(inv_depths.index_select(0, std::get<0>(torch::_unique(tgt_index))).reshape({-1}).median(0))
                  .item<double>();
  }
  if (!(median_depth > 0) || !std::isfinite(median_depth))
    throw std::invalid_argument("PhotometricBundleAdjust: inverse depths must be > 0");
  torch::Tensor initial = cam_from_world.to(torch::kDouble).clone();
  initial.slice(1, 0, 3).select(2, 3).div_(median_depth);
  const torch::Tensor initial32 = initial.to(torch::kFloat);
  const torch::Tensor inv32 = inv_depths.to(torch::kFloat) * median_depth;

  const int64_t gh = (height + options.depth_grid_stride - 1) / options.depth_grid_stride;
  const int64_t gw = (width + options.depth_grid_stride - 1) / options.depth_grid_stride;
  torch::Tensor delta = torch::zeros({v, 6}, torch::kFloat).requires_grad_(options.optimize_poses);
  torch::Tensor grid = torch::zeros({v, 1, gh, gw}, torch::kFloat).requires_grad_(options.optimize_depth);
  torch::Tensor mask = torch::ones({v, 1}, torch::kFloat);
  mask[fixed_camera] = 0;
  const auto cameras = [&] { return Se3Update(delta * mask, initial32); };

  const auto make_problem = [&](int level) {
    Problem p;
    const int64_t h = std::max<int64_t>(1, height >> level), w = std::max<int64_t>(1, width >> level);
    p.images = AreaDownsample(images32, h, w);
    p.intrinsics = ResizeIntrinsics(k32, static_cast<double>(w) / width, static_cast<double>(h) / height);
    p.inv_depths = AreaDownsample(inv32, h, w);
    p.tgt = tgt_index, p.src = src_index;
    p.clip_std_factor = options.clip_std_factor;
    p.ssim_weight = options.ssim_weight;
    return p;
  };
  const Problem full = make_problem(0);
  if (!pairs.empty()) result.initial_loss = PhotometricTerm(full, cameras(), grid).item<double>();

  for (int level = options.levels - 1; level >= 0 && !pairs.empty(); --level) {
    const Problem p = make_problem(level);
    // Finer levels take smaller steps: their basin is narrower and the coarse level did the rest.
    const double scale = std::pow(0.5, options.levels - 1 - level);
    // One Adam group per optimised block: the pose twists, the depth grid; their step sizes.
    std::vector<torch::optim::OptimizerParamGroup> groups;
    std::vector<double> steps;
    if (options.optimize_poses) {
      groups.emplace_back(std::vector<torch::Tensor>{delta},
                          std::make_unique<torch::optim::AdamOptions>(options.pose_step * scale));
      steps.push_back(options.pose_step * scale);
    }
    if (options.optimize_depth) {
      groups.emplace_back(std::vector<torch::Tensor>{grid},
                          std::make_unique<torch::optim::AdamOptions>(options.depth_step * scale));
      steps.push_back(options.depth_step * scale);
    }
    if (groups.empty()) break;
    torch::optim::Adam adam(groups, torch::optim::AdamOptions(steps[0]));
    for (int it = 0; it < options.iterations_per_level; ++it) {
      // Cosine decay to 5 % within the level, so the last steps settle instead of dithering at lr.
      const double decay = 0.05 + 0.95 * 0.5 * (1 + std::cos(M_PI * it / std::max(1, options.iterations_per_level)));
      for (size_t g = 0; g < steps.size(); ++g) adam.param_groups()[g].options().set_lr(steps[g] * decay);
      torch::AutoGradMode grad(true);
      adam.zero_grad();
      torch::Tensor loss = PhotometricTerm(p, cameras(), grid);
      if (options.optimize_depth && options.smoothness_weight > 0)
        loss = loss + options.smoothness_weight * Smoothness(grid);
      loss.backward();
      adam.step();
      ++result.iterations;
    }
  }
  if (!pairs.empty())
    result.final_loss = PhotometricTerm(full, cameras(), grid, &result.final_valid_fraction).item<double>();
  torch::Tensor refined = cameras().to(torch::kDouble);
  refined.slice(1, 0, 3).select(2, 3).mul_(median_depth);
  // The fixed camera exactly as given (float rounding aside, its update is the identity).
  refined[fixed_camera] = cam_from_world[fixed_camera].to(torch::kDouble);
  result.cam_from_world = refined;
  const torch::Tensor correction = F::interpolate(grid, F::InterpolateFuncOptions()
                                                            .size(std::vector<int64_t>{height, width})
                                                            .mode(torch::kBilinear)
                                                            .align_corners(false));
  result.inv_depths = inv32 * torch::exp(correction) / median_depth;
  result.seconds = timer.Seconds();
  return result;
}

}  // namespace nerfreg
