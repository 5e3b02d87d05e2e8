#include "nerfreg/dbarf/sfm_loss.h"

#include <cmath>

#include "nerfreg/dbarf/inverse_warp.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

namespace F = torch::nn::functional;

torch::Tensor Pool3(const torch::Tensor& x) { return F::avg_pool2d(x, F::AvgPool2dFuncOptions(3).stride(1)); }

}  // namespace

bool SfmLossOptions::Check() const {
  if (!(ssim_weight >= 0.0 && ssim_weight <= 1.0)) {
    LOG_ERROR("SfmLossOptions: ssim_weight must lie in [0, 1]");
    return false;
  }
  if (!(prediction_decay > 0.0 && prediction_decay <= 1.0)) {
    LOG_ERROR("SfmLossOptions: prediction_decay must lie in (0, 1]");
    return false;
  }
  if (!(smoothness_weight >= 0.0)) {
    LOG_ERROR("SfmLossOptions: smoothness_weight must be >= 0");
    return false;
  }
  if (pyramid_levels < 1 || pyramid_levels > 6) {
    LOG_ERROR("SfmLossOptions: pyramid_levels must lie in [1, 6]");
    return false;
  }
  return true;
}

torch::Tensor Ssim(const torch::Tensor& x, const torch::Tensor& y) {
  TORCH_CHECK(x.dim() == 4 && y.dim() == 4, "Ssim: expected [B, C, H, W] inputs");
  constexpr double kC1 = 1e-4, kC2 = 9e-4;
  const auto pad = F::PadFuncOptions({1, 1, 1, 1}).mode(torch::kReflect);
  const torch::Tensor xp = F::pad(x, pad), yp = F::pad(y.expand_as(x), pad);
  const torch::Tensor mu_x = Pool3(xp), mu_y = Pool3(yp);
  const torch::Tensor sigma_x = Pool3(xp * xp) - mu_x * mu_x;
  const torch::Tensor sigma_y = Pool3(yp * yp) - mu_y * mu_y;
  const torch::Tensor sigma_xy = Pool3(xp * yp) - mu_x * mu_y;
  const torch::Tensor num = (2 * mu_x * mu_y + kC1) * (2 * sigma_xy + kC2);
  const torch::Tensor den = (mu_x * mu_x + mu_y * mu_y + kC1) * (sigma_x + sigma_y + kC2);
  return num / den;
}

torch::Tensor PhotometricErrorMap(const torch::Tensor& pred, const torch::Tensor& target, double ssim_weight) {
  TORCH_CHECK(pred.dim() == 4 && target.dim() == 4 && pred.size(1) == target.size(1) &&
                  pred.size(2) == target.size(2) && pred.size(3) == target.size(3),
              "PhotometricErrorMap: pred [B, C, H, W] and target [1|B, C, H, W] differ: ", pred.sizes(), " vs ",
              target.sizes());
  const torch::Tensor l1 = (pred - target).abs().mean(1, true);
  const torch::Tensor dssim = ((1.0 - Ssim(pred, target)) * 0.5).clamp(0.0, 1.0).mean(1, true);
  return ssim_weight * dssim + (1.0 - ssim_weight) * l1;
}

torch::Tensor ClipErrorMaps(const torch::Tensor& errors, double factor) {
  TORCH_CHECK(errors.dim() == 4 && errors.size(1) == 1, "ClipErrorMaps: expected [B, 1, H, W], got ", errors.sizes());
  if (factor < 0) return errors;
  const torch::Tensor flat = errors.detach().flatten(1);
  const torch::Tensor limit = (flat.mean(1) + factor * flat.std(1)).view({-1, 1, 1, 1});
  return torch::minimum(errors, limit);
}

torch::Tensor EdgeAwareSmoothness(const torch::Tensor& inv_depth, const torch::Tensor& image) {
  TORCH_CHECK(inv_depth.dim() == 4 && inv_depth.size(1) == 1, "EdgeAwareSmoothness: inverse depth [B, 1, H, W]");
  TORCH_CHECK(image.dim() == 4 && image.size(2) == inv_depth.size(2) && image.size(3) == inv_depth.size(3),
              "EdgeAwareSmoothness: image [B, C, H, W] of the same size as the inverse depth");
  const torch::Tensor d = inv_depth / (inv_depth.mean({2, 3}, true) + 1e-7);
  const auto dx = [](const torch::Tensor& t) { return t.narrow(3, 0, t.size(3) - 1) - t.narrow(3, 1, t.size(3) - 1); };
  const auto dy = [](const torch::Tensor& t) { return t.narrow(2, 0, t.size(2) - 1) - t.narrow(2, 1, t.size(2) - 1); };
  const torch::Tensor wx = torch::exp(-dx(image).abs().mean(1, true));
  const torch::Tensor wy = torch::exp(-dy(image).abs().mean(1, true));
  return (dx(d).abs() * wx).mean() + (dy(d).abs() * wy).mean();
}

PhotometricLossResult PhotometricLoss(const torch::Tensor& target, const torch::Tensor& sources,
                                      const torch::Tensor& tgt_inv_depth, const torch::Tensor& src_from_tgt,
                                      const torch::Tensor& intrinsics, const SfmLossOptions& options,
                                      const torch::Tensor& src_intrinsics) {
  TORCH_CHECK(target.dim() == 4 && target.size(0) == 1, "PhotometricLoss: target must be [1, C, H, W], got ",
              target.sizes());
  TORCH_CHECK(sources.dim() == 4 && sources.sizes().slice(1) == target.sizes().slice(1),
              "PhotometricLoss: sources must be [N, C, H, W] like the target, got ", sources.sizes());
  TORCH_CHECK(tgt_inv_depth.dim() == 4 && tgt_inv_depth.size(0) == 1 && tgt_inv_depth.size(1) == 1 &&
                  tgt_inv_depth.size(2) == target.size(2) && tgt_inv_depth.size(3) == target.size(3),
              "PhotometricLoss: inverse depth must be [1, 1, H, W] at the image size, got ", tgt_inv_depth.sizes());
  const InverseWarpResult warp = InverseWarp(sources, tgt_inv_depth, src_from_tgt, intrinsics,
                                             src_intrinsics.defined() ? src_intrinsics : intrinsics);
  torch::Tensor warped_err =
      ClipErrorMaps(PhotometricErrorMap(warp.warped, target, options.ssim_weight), options.clip_std_factor);
  warped_err = torch::where(warp.valid > 0.5, warped_err, torch::full_like(warped_err, kInvalidError));
  torch::Tensor all = warped_err;
  if (options.auto_mask) {
    const torch::Tensor identity_err =
        ClipErrorMaps(PhotometricErrorMap(sources, target, options.ssim_weight), options.clip_std_factor);
    all = torch::cat({warped_err, identity_err}, 0);
  }
  PhotometricLossResult result;
  result.min_error = std::get<0>(all.min(0, true));  // [1, 1, H, W]
  const torch::Tensor counted = (result.min_error < 0.5 * kInvalidError).to(target.scalar_type());
  result.loss = (result.min_error * counted).sum() / counted.sum().clamp_min(1.0);
  result.warped = warp.warped;
  result.valid = warp.valid;
  return result;
}

SfmLossResult SfmLoss(const torch::Tensor& target, const torch::Tensor& sources,
                      const std::vector<torch::Tensor>& inv_depths, const std::vector<torch::Tensor>& src_from_tgts,
                      const torch::Tensor& intrinsics, const SfmLossOptions& options) {
  TORCH_CHECK(options.Check(), "SfmLoss: invalid options");
  TORCH_CHECK(!inv_depths.empty() && inv_depths.size() == src_from_tgts.size(),
              "SfmLoss: need K >= 1 inverse depths and as many pose sets, got ", inv_depths.size(), " and ",
              src_from_tgts.size());
  const int64_t k_count = static_cast<int64_t>(inv_depths.size());
  std::vector<torch::Tensor> photometric, smoothness;
  torch::Tensor total = torch::zeros({}, target.options());
  const int64_t coarsest = int64_t{1} << (options.pyramid_levels - 1);
  TORCH_CHECK(target.size(2) >= 4 * coarsest && target.size(3) >= 4 * coarsest, "SfmLoss: ", options.pyramid_levels,
              " pyramid levels need images of at least ", 4 * coarsest, " px a side, got ", target.sizes());
  // The pyramid's images, built once: level l (H >> l by W >> l) at index l - 1.
  const int64_t height = target.size(2), width = target.size(3);
  std::vector<torch::Tensor> pooled_targets, pooled_sources, pooled_intrinsics;
  for (int l = 1; l < options.pyramid_levels; ++l) {
    const int64_t h = height >> l, w = width >> l;
    pooled_targets.push_back(AreaDownsample(target, h, w));
    pooled_sources.push_back(AreaDownsample(sources, h, w));
    pooled_intrinsics.push_back(ResizeIntrinsics(intrinsics, static_cast<double>(w) / static_cast<double>(width),
                                                 static_cast<double>(h) / static_cast<double>(height)));
  }
  for (int64_t k = 0; k < k_count; ++k) {
    photometric.push_back(PhotometricLoss(target, sources, inv_depths[k], src_from_tgts[k], intrinsics, options).loss);
    smoothness.push_back(EdgeAwareSmoothness(inv_depths[k], target));
    torch::Tensor pyramid = photometric.back();
    for (int l = 1; l < options.pyramid_levels; ++l) {
      const torch::Tensor inv = AreaDownsample(inv_depths[k], height >> l, width >> l);
      pyramid = pyramid + PhotometricLoss(pooled_targets[l - 1], pooled_sources[l - 1], inv, src_from_tgts[k],
                                          pooled_intrinsics[l - 1], options)
                              .loss;
    }
    const double w = std::pow(options.prediction_decay, static_cast<double>(k_count - 1 - k));
    const double s = options.smoothness_weight / std::pow(2.0, static_cast<double>(k));
    total = total + w * pyramid + s * smoothness.back();
  }
  return {total, torch::stack(photometric), torch::stack(smoothness)};
}

}  // namespace nerfreg
