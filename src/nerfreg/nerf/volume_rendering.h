#pragma once
// Ray marching with empty-space skipping and volume compositing, as fused C++ kernels.
//
// Samples are packed (CSR): ray r owns samples [offsets[r], offsets[r+1]). Compositing per ray:
//   alpha_i = 1 - exp(-sigma_i * delta_i), T_i = prod_{j<i} (1 - alpha_j), w_i = T_i alpha_i,
//   colour = sum w_i rgb_i, opacity = sum w_i, depth = sum w_i t_i,
// stopping once T < early_stop (1e-4). The backward pass uses
//   d colour / d sigma_i = delta_i (T_{i+1} rgb_i - (colour - colour_{<=i}))
// (and likewise for opacity and depth), so nothing per sample has to be stored.
//
// In the CUDA build (NERFREG_WITH_CUDA) both also run on the GPU when their tensors are CUDA ones
// (volume_rendering.cu): one thread per ray, the CPU kernels' arithmetic and early stop.
#include <torch/torch.h>

#include "nerfreg/nerf/occupancy_grid.h"

namespace nerfreg {

struct MarchOptions {
  double step_size = 3.0 * 1.7320508075688772 / 1024;  // world units (spec: 3 sqrt(3) / 1024 for a 3-wide box)
  double near = 0.05;                                  // no samples closer to the camera than this
  int max_samples_per_ray = 1024;
  bool perturb = false;  // random start offset per ray (training)
  void Check() const;
};

struct RaySamples {
  torch::Tensor offsets;   // [R + 1] int64
  torch::Tensor t_starts;  // [S] float32
  torch::Tensor t_ends;    // [S] float32
  torch::Tensor ray_ids;   // [S] int64
};

// origins, dirs: [R, 3] float32 (dirs unit length). Samples lie inside the grid's AABB and in
// occupied cells only. In the CUDA build, CUDA origins are marched on the GPU against
// grid.occupied() moved there (a no-op for a grid already on it) and the samples stay there; they
// are the CPU's samples, also with perturb: its start offsets are drawn from `gen` on the CPU and
// copied. Otherwise the samples are on the CPU.
RaySamples MarchRays(const torch::Tensor& origins, const torch::Tensor& dirs, const OccupancyGrid& grid,
                     const MarchOptions& options, torch::Generator gen = {});

struct CompositeResult {
  torch::Tensor rgb;      // [R, 3]
  torch::Tensor opacity;  // [R]
  torch::Tensor depth;    // [R] expected ray distance (t), not normalised by opacity
};

// sigmas [S], rgbs [S, 3], t_starts/t_ends [S] float32, offsets [R + 1]; the other tensors are
// moved to sigmas' device. Differentiable in sigmas, rgbs. Devices without a kernel
// (CompositeHasKernel) fall back to CompositeReference.
CompositeResult Composite(const torch::Tensor& sigmas, const torch::Tensor& rgbs, const torch::Tensor& t_starts,
                          const torch::Tensor& t_ends, const torch::Tensor& offsets, double early_stop = 1e-4);
// Whether Composite has a fused kernel for `device`: the CPU always, CUDA in the CUDA build.
bool CompositeHasKernel(const torch::Device& device);
// The same with torch ops (per-ray loop over cumprod), for tests and benchmarks.
CompositeResult CompositeReference(const torch::Tensor& sigmas, const torch::Tensor& rgbs,
                                   const torch::Tensor& t_starts, const torch::Tensor& t_ends,
                                   const torch::Tensor& offsets, double early_stop = 1e-4);

}  // namespace nerfreg
