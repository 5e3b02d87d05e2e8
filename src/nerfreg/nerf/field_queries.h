#pragma once
// What registration asks of a trained block, from its field alone (no images):
//  - density / alpha at arbitrary points;
//  - the surface field S(X) (spec dreg-nerf.md 3): from each training camera that sees X, march
//    the ray towards X (stopping at it) and take max_i alpha_i T_i; OR over the cameras (a max).
//    S is the probability that a camera ray hits a surface at X: ~1 on surfaces seen by the
//    cameras, ~0 in empty space and behind surfaces. Two other per-ray measures
//    (SurfaceFieldOptions::mode): the opacity up to X, and the weight within a window around X
//    (what grid extraction uses: it does not shrink with the march step on blurry fields);
//  - the block's occupied points: one jittered point per occupied cell with density, view-averaged
//    colour and alpha (the voxel grid DReg-NeRF feeds its network).
#include <torch/torch.h>

#include <string>

#include "nerfreg/nerf/nerf_block.h"

namespace nerfreg {

// positions [N, 3] -> sigma [N], without gradients, in chunks.
torch::Tensor QueryDensity(NerfBlock& block, const torch::Tensor& positions);

struct SurfaceFieldOptions {
  int max_cameras = 16;      // training cameras marched from, evenly spaced over the training split
  double step_size = 0.0;    // march step; 0: the block's marching step
  double stop_before = 0.0;  // stop this far before X (0: at X, as the spec says)
  // Per ray: "max_weight" is the spec's max_i alpha_i T_i; "opacity" is the opacity accumulated
  // up to X, 1 - T(X) = sum_i alpha_i T_i. On a sharp surface both are ~1; on the blurrier blocks
  // a CPU trains in minutes a surface spreads its weight over several samples, so the maximum
  // weight stays below the 0.5 threshold while the accumulated opacity still reaches it.
  // "window": the ray's weight within half a `window` of X, T(X - w/2) - T(X + w/2): the chance
  // that the ray ends within that stretch. Unlike max_weight it does not shrink with the march
  // step (a blurry surface spread over several samples still sums to ~1 within a cell), and
  // unlike opacity it is ~0 inside a solid (the ray has ended before it gets there): the visible
  // surface, as a block's cameras saw it.
  std::string mode = "max_weight";
  double window = 0.0;  // mode "window": the stretch's length, scene units (> 0; grid extraction: 0 = a cell)
  // A ray stops marching once its transmittance is below this: the steps it skips could add at
  // most this much to its measure (every mode), so S changes by less than it. 0: every step.
  double min_transmittance = 1e-5;
  void Check() const;
};

// points [N, 3] -> S [N] in [0, 1].
torch::Tensor SurfaceField(NerfBlock& block, const torch::Tensor& points, const SurfaceFieldOptions& options);

struct BlockPoints {
  torch::Tensor xyz;    // [N, 3] block frame
  torch::Tensor rgb;    // [N, 3] colour averaged over 6 viewing directions
  torch::Tensor sigma;  // [N]
  torch::Tensor alpha;  // [N] clip(1 - exp(-0.01 sigma), 0, 1) (spec section 3)
};

// Colour averaged over the six axis directions at positions [N, 3] (block frame) -> [N, 3].
torch::Tensor ViewAveragedColor(NerfBlock& block, const torch::Tensor& positions);

// One jittered point per occupied cell of the block's grid whose density exceeds
// `min_density` (spec: 0.7). shell: only the cells of that dense set with a cell outside it among
// their 26 neighbours (the grid's outside counts as outside): the solid's boundary, one cell thick.
// A trained block fills what its cameras saw around with density; a surface capture (splats) is a
// shell, and points of the solid's inside have nothing to match there.
BlockPoints ExtractOccupiedPoints(NerfBlock& block, double min_density = 0.7, unsigned seed = 0, bool shell = false);

}  // namespace nerfreg
