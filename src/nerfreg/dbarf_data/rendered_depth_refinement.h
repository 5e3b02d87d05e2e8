// The last stage of `dbarf finetune --refine-cameras`: the scene's cameras bundle-adjusted
// photometrically (dbarf/photometric_bundle_adjustment.h) through the depths the finetuned
// renderer gives at them.
//
// Why: the finetune's RGB loss moves the cameras through a renderer that co-adapts with them, and
// at the network's sub-degree errors (about half a pixel at 128 x 96) that loss is nearly flat in
// the cameras: measured, the finetune left them within +-0.04 deg of where it started. The
// renderer's depths are what the finetune does improve; a warp of every view into its neighbours
// through those depths has its sharp minimum at the right relative poses, so the cameras are
// refined there, the depths given a smooth correction alongside (the warp's own BA), round after
// round from the new cameras.
//
//  - Targets: every view with a camera, held-out ones included (their pixels place them, as they
//    do in dbarf poses); sources and the renderer's inputs: the nearest usable views only, so a
//    held-out image never enters the renderer.
//  - Gauge: the first usable view is fixed, and the scale is brought back to the input's (mean
//    distance of the usable cameras to the fixed one), so the renderer's depth range still holds.
#pragma once

#include <torch/torch.h>

#include <vector>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/dbarf/photometric_bundle_adjustment.h"

namespace nerfreg {

struct RenderedDepthRefinementOptions {
  int rounds = 1;  // render the depths, bundle-adjust; again from the new cameras (0: off)
  // Nearest usable views per target: the renderer's inputs and the warps' sources. 8 (with the
  // second render below) against 4 on validation: rotations closer on all 3 scenes, centres
  // 2.4-4.4x closer (docs/poses_and_views.md, "The last stage").
  int num_sources = 8;
  // Render and warp at most this wide (0: the scene's size). At 320x240 the full size took over 15
  // minutes on one busy core for 20 views; 160 wide takes about 4.
  int max_width = 160;
  // Render each view twice: over the scene's depth range, then over the range that render spans
  // (ViewDepthRange, widened by this factor each way). The renderer's samples (32 in the CPU
  // configuration) are uniform in inverse depth over the range; over the scene's, as dbarf poses
  // sets it, they sat 7.5-10 % of the depth apart on validation, the size of the depths' errors
  // (docs/poses_and_views.md, "The last stage"). 0: one render, over the scene's range.
  double view_range_margin = 1.2;
  PhotometricBundleAdjustmentOptions ba = DefaultBundleAdjustment();
  void Check() const;  // throws InputError naming the option

  // The cameras start within a pixel or two: two pyramid levels. 100 steps a level: 300 moved
  // validation rotations both ways (docs/poses_and_views.md, "The last stage").
  static PhotometricBundleAdjustmentOptions DefaultBundleAdjustment() {
    PhotometricBundleAdjustmentOptions o;
    o.levels = 2;
    o.iterations_per_level = 100;
    o.pose_step = 1e-3;
    // Finer than the network BA's 8: the rendered depths' errors have more detail than the
    // network's (docs/poses_and_views.md, "The last stage").
    o.depth_grid_stride = 4;
    return o;
  }
};

struct RenderedDepthRefinementResult {
  torch::Tensor cam_from_world;      // [V, 4, 4] float32, refined (the input where a view had none)
  std::vector<double> initial_loss;  // per round, the photometric error before and after its BA
  std::vector<double> final_loss;
  int pairs = 0;  // (target, source) warps per round
  double seconds = 0;
};

// scene: the finetuned scene (its images, intrinsics, usable views, depth range; its cameras are
// not read); cam_from_world: [V, 4, 4] the finetune's cameras in the scene's frame. The model is
// used for rendering only (no gradients, eval mode).
RenderedDepthRefinementResult RefineCamerasWithRenderedDepths(DbarfModel& model, const DbarfScene& scene,
                                                              const torch::Tensor& cam_from_world,
                                                              const RenderedDepthRefinementOptions& options);

}  // namespace nerfreg
