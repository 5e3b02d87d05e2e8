// Photometric bundle adjustment of global cameras with per-image inverse depth (DBARF's SfM loss,
// spec dbarf.md 4, turned from a training loss into a refinement of a whole image set): every
// (target, source) pair warps the source into the target through the target's inverse depth and
// the relative pose src_from_world * tgt_from_world^-1, and the SSIM + L1 error of the warp
// (sfm_loss.h) is minimised over all cameras at once and over a smooth correction of every inverse
// depth map. No keypoints: the correspondences are the dense warps the network's depths define.
//
//  - Cameras: cam_from_world_k = Exp(delta_k) * initial_k (left update, se3.h); fixed_camera's
//    delta stays 0 (the rotation / translation gauge). The scale gauge is left free (a warp does
//    not see it); callers re-normalise the frame.
//  - Depths: inv_depth_k = initial_k * exp(g_k), g_k a coarse grid (1 / depth_grid_stride of the
//    image) upsampled bilinearly, with a first-difference smoothness penalty: the network's depths
//    are smooth and mostly right up to a per-image scale, which the grid's mean absorbs.
//  - The solve is Adam on a coarse-to-fine pyramid (2x average pooling per level): the warps'
//    basin is a few pixels wide at each level, and the coarse levels bring a pose that is a few
//    pixels off at full resolution into it.
//  - Robustness: per pair, errors above mean + clip_std_factor * std (detached) are clipped
//    (occlusions, specularities), and pixels that warp outside the source do not count.
// Internally the world is scaled so that the median depth is 1, so the step sizes are in radians
// and in median depths whatever the scene's units.
#pragma once

#include <torch/torch.h>

#include <utility>
#include <vector>

namespace nerfreg {

struct PhotometricBundleAdjustmentOptions {
  int levels = 3;                   // pyramid levels (1: full resolution only)
  int iterations_per_level = 60;    // Adam steps per level
  double pose_step = 2e-3;          // Adam learning rate of the pose twists (rad; median depths)
  double depth_step = 1e-2;         // Adam learning rate of the log inverse-depth grid
  int depth_grid_stride = 8;        // the depth correction's grid: 1 cell per stride x stride pixels
  bool optimize_depth = true;       // false: the depths are held as given (poses only)
  bool optimize_poses = true;       // false: the cameras are held (depths only: how well they explain the images)
  double smoothness_weight = 0.05;  // on the squared first differences of the log-depth grid
  double ssim_weight = 0.85;        // SSIM vs L1 in the per-pixel error (sfm_loss.h)
  double clip_std_factor = 1.0;     // robust clipping per pair; < 0 disables
  void Check() const;               // throws InputError naming the option
};

struct PhotometricBundleAdjustmentResult {
  torch::Tensor cam_from_world;  // [V, 4, 4] float64, refined (fixed_camera's unchanged)
  torch::Tensor inv_depths;      // [V, 1, H, W] float32, refined, in the input's units
  double initial_loss = 0;       // mean photometric error over valid pixels, full resolution
  double final_loss = 0;
  // The share of the pairs' target pixels that warp inside their source at the end: the losses
  // count only those, so cameras that make few pixels overlap can score low on them.
  double final_valid_fraction = 0;
  int iterations = 0;
  double seconds = 0;
};

// images: [V, 3, H, W] float32 in [0, 1]; intrinsics: [V, 3, 3] float32 (pixels of H x W);
// inv_depths: [V, 1, H, W] float32 > 0 (per image, in the cameras' units; only targets' are used);
// cam_from_world: [V, 4, 4] (any float dtype); pairs: (target, source) image indices, distinct,
// in [0, V). Throws std::invalid_argument on inconsistent shapes / indices.
PhotometricBundleAdjustmentResult PhotometricBundleAdjust(const torch::Tensor& images, const torch::Tensor& intrinsics,
                                                          const torch::Tensor& inv_depths,
                                                          const torch::Tensor& cam_from_world,
                                                          const std::vector<std::pair<int, int>>& pairs,
                                                          int fixed_camera,
                                                          const PhotometricBundleAdjustmentOptions& options);

}  // namespace nerfreg
