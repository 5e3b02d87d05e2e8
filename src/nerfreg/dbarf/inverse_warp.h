// Inverse warping of a source image (or feature map) into a target view, given the target's
// inverse depth, the relative pose src_from_tgt and pinhole intrinsics. The one geometric
// operation shared by DBARF's feature-metric cost maps (at 1/8 resolution) and its photometric
// SfM loss (at image resolution), and by photometric pose refinement outside the network.
//
// Conventions (project-wide, see geometry/camera.h):
//  - Intrinsics K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] in pixels of the image they describe;
//    pixel (col, row) has its centre at (col + 0.5, row + 0.5); OpenCV axes (+z forward).
//  - Sampling: torch grid_sample, bilinear, align_corners = false, normalised coordinates
//    (2u/W - 1, 2v/H - 1); padding "border" (edge pixels repeat instead of fading to black).
//  - A map at 1/s resolution takes ScaleIntrinsics(K, 1/s): fx, fy, cx, cy all scaled (spec 9.1).
#pragma once

#include <torch/torch.h>

namespace nerfreg {

// Returns a scaled copy of K ([3, 3] or [N, 3, 3], float): rows 0 and 1 (fx, cx, fy, cy) times
// scale. The input is never modified.
torch::Tensor ScaleIntrinsics(const torch::Tensor& intrinsics, double scale);

// The same per axis, for an image resized to sx W x sy H: fx, cx times sx; fy, cy times sy.
torch::Tensor ResizeIntrinsics(const torch::Tensor& intrinsics, double sx, double sy);

// Maps [B, C, H, W] area-downsampled to h x w (each output pixel the mean over its footprint; for
// H = f h, W = f w the mean of f x f blocks). With ResizeIntrinsics(K, w / W, h / H) the pixel
// centres (+0.5) stay consistent: the levels of an image pyramid.
torch::Tensor AreaDownsample(const torch::Tensor& x, int64_t h, int64_t w);

// Homogeneous pixel centres of an H x W image, row-major: [H * W, 3] = (col + 0.5, row + 0.5, 1).
torch::Tensor PixelCentres(int64_t height, int64_t width, const torch::TensorOptions& options);

// Back-projects every target pixel with its inverse depth.
// tgt_inv_depth: [B, 1, H, W] float, > 0; intrinsics: [3, 3] or [B, 3, 3].
// Returns x_in_tgt [B, H * W, 3] (row-major pixels).
torch::Tensor BackProject(const torch::Tensor& tgt_inv_depth, const torch::Tensor& intrinsics);

struct InverseWarpResult {
  // [N, C, H, W]: source sampled where each target pixel lands (border padding).
  torch::Tensor warped;
  // [N, 1, H, W] float 0/1: the point lies in front of source i (z > 1e-4) and projects inside
  // the hull of its pixel centres [0.5, Ws - 0.5] x [0.5, Hs - 0.5] (no padding is read).
  torch::Tensor valid;
  // [N, H, W, 2]: the normalised grid_sample coordinates used.
  torch::Tensor grid;
};

// Warps each source i into the target view.
//  source:           [N, C, Hs, Ws] float (images or feature maps).
//  tgt_inv_depth:    [1 or N, 1, H, W] float, > 0 (one map shared by all sources, or one each).
//  src_from_tgt:     [N, 4, 4] float: x_in_src_i = R x_in_tgt + t.
//  tgt_intrinsics:   [3, 3] or [N, 3, 3] float, for the H x W target map.
//  src_intrinsics:   [3, 3] or [N, 3, 3] float, for the Hs x Ws source maps.
// Differentiable w.r.t. source, tgt_inv_depth and src_from_tgt.
InverseWarpResult InverseWarp(const torch::Tensor& source, const torch::Tensor& tgt_inv_depth,
                              const torch::Tensor& src_from_tgt, const torch::Tensor& tgt_intrinsics,
                              const torch::Tensor& src_intrinsics);
// Same camera for target and sources.
InverseWarpResult InverseWarp(const torch::Tensor& source, const torch::Tensor& tgt_inv_depth,
                              const torch::Tensor& src_from_tgt, const torch::Tensor& intrinsics);

}  // namespace nerfreg
