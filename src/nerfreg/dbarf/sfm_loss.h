// DBARF's self-supervised structure-from-motion loss (spec dbarf.md 4): sources are inverse-warped
// into the target with the predicted inverse depth and relative poses, and compared with a
// monodepth2-style SSIM + L1 photometric error, clipped, auto-masked, and combined over the
// network's successive predictions; plus edge-aware smoothness of the inverse depth.
//
// The pieces are free functions on explicit tensors so that the same photometric objective can
// refine poses and depths outside the network (per-image poses and inverse-depth maps optimised
// over the pairs of a view graph): see PhotometricLoss.
//
// Images are [*, C, H, W] float in [0, 1]; inverse depth [1, 1, H, W] at the image resolution.
#pragma once

#include <torch/torch.h>

#include <vector>

namespace nerfreg {

struct SfmLossOptions {
  // Weight of the SSIM term in the per-pixel error; (1 - weight) goes to L1. Paper 0.85.
  double ssim_weight = 0.85;
  // Each error map is clipped at mean + clip_std_factor * std (statistics detached); < 0 disables.
  double clip_std_factor = 0.5;
  // Auto-masking: the un-warped source errors join the per-pixel minimum, so pixels that a static
  // (unmoved) source explains better than any warp are ignored.
  bool auto_mask = true;
  // Prediction k of K gets weight prediction_decay^(K - 1 - k) (the last prediction weighs 1).
  double prediction_decay = 0.85;
  // Smoothness weight for prediction k: smoothness_weight / 2^k.
  double smoothness_weight = 0.01;
  // Levels of an image pyramid the photometric term is summed over (1: the full resolution alone,
  // the original). Level l area-downsamples the images and the inverse depth to (H >> l) x (W >> l),
  // intrinsics to match (inverse_warp.h's AreaDownsample, ResizeIntrinsics). From the identity the
  // coarser levels' descent direction lies closer to the true poses
  // (docs/notes/2026-11-30-dbarf-fresh-heads-pyramid.md).
  int pyramid_levels = 1;

  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

// Structural similarity per pixel and channel: 3x3 average pooling on reflect-padded inputs,
// C1 = 1e-4, C2 = 9e-4. x, y: [B, C, H, W] float (y may broadcast over B). Returns [B, C, H, W].
torch::Tensor Ssim(const torch::Tensor& x, const torch::Tensor& y);

// Per-pixel photometric error ssim_weight * clamp((1 - SSIM) / 2, 0, 1) + (1 - ssim_weight) * L1,
// averaged over channels. pred [B, C, H, W], target [1 or B, C, H, W] -> [B, 1, H, W].
torch::Tensor PhotometricErrorMap(const torch::Tensor& pred, const torch::Tensor& target, double ssim_weight = 0.85);

// Clips each map b of errors [B, 1, H, W] at its own mean + factor * std (detached statistics).
torch::Tensor ClipErrorMaps(const torch::Tensor& errors, double factor);

// Edge-aware smoothness of the mean-normalised inverse depth: mean(|dx d| exp(-mean_c |dx I|)) +
// the same along y. inv_depth [1, 1, H, W], image [1, C, H, W] -> scalar.
torch::Tensor EdgeAwareSmoothness(const torch::Tensor& inv_depth, const torch::Tensor& image);

struct PhotometricLossResult {
  // Scalar: mean over valid pixels of the per-pixel minimum over the error maps.
  torch::Tensor loss;
  // [1, 1, H, W]: that per-pixel minimum (pixels no warp sees hold kInvalidError).
  torch::Tensor min_error;
  // [N, C, H, W] warped sources and [N, 1, H, W] their validity (see InverseWarp).
  torch::Tensor warped;
  torch::Tensor valid;
};

// Error assigned to warped pixels that fall outside the source or behind it: larger than any
// photometric error (which lies in [0, 1] for images in [0, 1]), so they never win the minimum.
constexpr double kInvalidError = 1e3;

// The photometric term for one prediction.
//  target:        [1, C, H, W] float.
//  sources:       [N, C, H, W] float.
//  tgt_inv_depth: [1, 1, H, W] float, > 0.
//  src_from_tgt:  [N, 4, 4] float.
//  intrinsics:    [3, 3] or [N, 3, 3] float, pixels of the H x W images (the target's camera).
//  src_intrinsics: undefined (the sources share `intrinsics`) or [3, 3] / [N, 3, 3] float.
PhotometricLossResult PhotometricLoss(const torch::Tensor& target, const torch::Tensor& sources,
                                      const torch::Tensor& tgt_inv_depth, const torch::Tensor& src_from_tgt,
                                      const torch::Tensor& intrinsics, const SfmLossOptions& options = {},
                                      const torch::Tensor& src_intrinsics = {});

struct SfmLossResult {
  torch::Tensor total;        // scalar: sum_k w_k (sum over pyramid levels of photometric) + s_k smoothness_k
  torch::Tensor photometric;  // [K] unweighted photometric term per prediction, full resolution
  torch::Tensor smoothness;   // [K] unweighted smoothness term per prediction
};

// The full loss over K predictions (K >= 1): inv_depths[k] [1, 1, H, W], src_from_tgts[k]
// [N, 4, 4]; other arguments as PhotometricLoss.
SfmLossResult SfmLoss(const torch::Tensor& target, const torch::Tensor& sources,
                      const std::vector<torch::Tensor>& inv_depths, const std::vector<torch::Tensor>& src_from_tgts,
                      const torch::Tensor& intrinsics, const SfmLossOptions& options = {});

}  // namespace nerfreg
