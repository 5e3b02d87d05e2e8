#pragma once
// The CUDA side of MarchRays() and Composite() (volume_rendering.cu, compiled only in the CUDA
// build): one thread per ray, the same arithmetic and the same early-stop rule as the CPU kernels
// in volume_rendering.cc. Every tensor is on one CUDA device and contiguous.
#include <ATen/ATen.h>

#include <array>
#include <cstdint>

namespace nerfreg {

// The grid and the step as plain data, computed once on the host so both devices march with the
// same float values.
struct MarchParams {
  float aabb_min[3];
  float aabb_max[3];
  float inv_cell[3];  // G / (aabb_max - aabb_min), cells per world unit
  std::int32_t resolution = 0;
  float near = 0;
  float step = 0;
  float half_step = 0;  // 0.5f * step, exact
  std::int32_t max_samples = 0;
};

// origins, dirs: [R, 3] float32; occupied: [G, G, G] bool; jitter: [R] float32 start offsets in
// steps, or undefined for 0.5. Returns {offsets [R + 1] int64, t_starts [S] float32,
// t_ends [S] float32, ray_ids [S] int64}: a counting pass, a cumsum and a filling pass.
std::array<at::Tensor, 4> MarchRaysCuda(const at::Tensor& origins, const at::Tensor& dirs, const at::Tensor& occupied,
                                        const at::Tensor& jitter, const MarchParams& params);

// sigmas [S], rgbs [S, 3], t_starts [S], t_ends [S] float32; offsets [R + 1] int64.
// Returns {rgb [R, 3], opacity [R], depth [R]}.
std::array<at::Tensor, 3> CompositeForwardCuda(const at::Tensor& sigmas, const at::Tensor& rgbs,
                                               const at::Tensor& t_starts, const at::Tensor& t_ends,
                                               const at::Tensor& offsets, float early_stop);
// The forward's inputs and outputs, and d loss / d (rgb [R, 3], opacity [R], depth [R]).
// Returns {d loss / d sigmas [S], d loss / d rgbs [S, 3]}, recomputed per ray from the outputs
// (the formula in volume_rendering.h), nothing stored per sample.
std::array<at::Tensor, 2> CompositeBackwardCuda(const at::Tensor& sigmas, const at::Tensor& rgbs,
                                                const at::Tensor& t_starts, const at::Tensor& t_ends,
                                                const at::Tensor& offsets, const at::Tensor& rgb,
                                                const at::Tensor& opacity, const at::Tensor& depth,
                                                const at::Tensor& grad_rgb, const at::Tensor& grad_opacity,
                                                const at::Tensor& grad_depth, float early_stop);

}  // namespace nerfreg
