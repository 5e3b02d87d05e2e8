// CUDA kernels of the multiresolution hash encoding (see hash_encoding.h): one thread per
// (point, level). The corner arithmetic is written with round-to-nearest intrinsics so nvcc
// cannot contract it into FMAs: the grid cell a point falls in is then the one the CPU kernel and
// the torch-ops reference pick, and the tests compare them to float rounding.
#include <ATen/ATen.h>
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>

#include "nerfreg/nerf/hash_encoding_cuda.h"

namespace nerfreg {
namespace {

constexpr std::uint32_t kPrime1 = 2654435761u, kPrime2 = 805459861u;
constexpr int kThreads = 256;

__device__ __forceinline__ std::uint32_t GridIndex(const HashLevelParams& li, std::uint32_t x, std::uint32_t y,
                                                   std::uint32_t z, std::uint32_t mask) {
  if (li.dense) {
    const std::uint32_t i = x + y * li.stride + z * li.stride * li.stride;
    return li.wrap ? i % li.rows : i & mask;
  }
  return (x ^ (y * kPrime1) ^ (z * kPrime2)) & mask;
}

__device__ __forceinline__ void Corners(const HashLevelParams& li, const float* p, std::uint32_t mask,
                                        std::uint32_t idx[8], float w[8]) {
  float frac[3];
  std::uint32_t base[3];
  for (int d = 0; d < 3; ++d) {
    const float pos = __fadd_rn(__fmul_rn(fminf(fmaxf(p[d], 0.f), 1.f), li.scale), 0.5f);
    base[d] = static_cast<std::uint32_t>(pos);
    frac[d] = __fsub_rn(pos, static_cast<float>(base[d]));
  }
  for (int c = 0; c < 8; ++c) {
    const std::uint32_t dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    w[c] = __fmul_rn(__fmul_rn(dx ? frac[0] : 1 - frac[0], dy ? frac[1] : 1 - frac[1]), dz ? frac[2] : 1 - frac[2]);
    idx[c] = GridIndex(li, base[0] + dx, base[1] + dy, base[2] + dz, mask);
  }
}

__global__ void ForwardKernel(const float* __restrict__ positions, const float* __restrict__ table,
                              float* __restrict__ out, std::int64_t n, HashGridParams grid) {
  const std::int64_t k = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  const int L = grid.levels, F = grid.features;
  if (k >= n * L) return;
  // Level-major within a block of threads: neighbouring threads read one level's table.
  const int l = static_cast<int>(k / n);
  const std::int64_t i = k - static_cast<std::int64_t>(l) * n;
  std::uint32_t idx[8];
  float w[8];
  Corners(grid.level[l], positions + 3 * i, grid.mask, idx, w);
  const float* t = table + static_cast<std::int64_t>(l) * grid.table_size * F;
  for (int f = 0; f < F; ++f) {
    float acc = 0;
    for (int c = 0; c < 8; ++c) acc += w[c] * __ldg(t + static_cast<std::int64_t>(idx[c]) * F + f);
    out[i * L * F + l * F + f] = acc;
  }
}

__global__ void BackwardKernel(const float* __restrict__ positions, const float* __restrict__ grad_out,
                               float* __restrict__ grad_table, std::int64_t n, HashGridParams grid) {
  const std::int64_t k = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  const int L = grid.levels, F = grid.features;
  if (k >= n * L) return;
  const int l = static_cast<int>(k / n);
  const std::int64_t i = k - static_cast<std::int64_t>(l) * n;
  std::uint32_t idx[8];
  float w[8];
  Corners(grid.level[l], positions + 3 * i, grid.mask, idx, w);
  float* t = grad_table + static_cast<std::int64_t>(l) * grid.table_size * F;
  const float* g = grad_out + i * L * F + l * F;
  for (int f = 0; f < F; ++f) {
    const float gf = g[f];
    if (gf == 0.f) continue;
    for (int c = 0; c < 8; ++c) atomicAdd(t + static_cast<std::int64_t>(idx[c]) * F + f, w[c] * gf);
  }
}

unsigned Blocks(std::int64_t work) { return static_cast<unsigned>((work + kThreads - 1) / kThreads); }

}  // namespace

at::Tensor HashEncodeForwardCuda(const at::Tensor& positions, const at::Tensor& table, const HashGridParams& grid) {
  TORCH_CHECK(positions.is_cuda() && table.is_cuda() && positions.device() == table.device(),
              "HashEncodeForwardCuda: positions and table must be on one CUDA device");
  TORCH_CHECK(grid.levels >= 1 && grid.levels <= kMaxHashLevels && grid.features >= 1 && grid.features <= 8,
              "HashEncodeForwardCuda: levels or features out of range");
  const c10::cuda::CUDAGuard guard(positions.device());
  const at::Tensor pos = positions.contiguous();
  const at::Tensor tab = table.contiguous();
  const std::int64_t n = pos.size(0);
  at::Tensor out = at::empty({n, static_cast<std::int64_t>(grid.levels) * grid.features}, pos.options());
  if (n == 0) return out;
  const auto stream = c10::cuda::getCurrentCUDAStream();
  ForwardKernel<<<Blocks(n * grid.levels), kThreads, 0, stream>>>(pos.data_ptr<float>(), tab.data_ptr<float>(),
                                                                  out.data_ptr<float>(), n, grid);
  C10_CUDA_KERNEL_LAUNCH_CHECK();
  return out;
}

at::Tensor HashEncodeBackwardCuda(const at::Tensor& positions, const at::Tensor& grad_out, const HashGridParams& grid) {
  TORCH_CHECK(positions.is_cuda() && grad_out.is_cuda(), "HashEncodeBackwardCuda: CUDA tensors expected");
  const c10::cuda::CUDAGuard guard(positions.device());
  const at::Tensor pos = positions.contiguous();
  const at::Tensor g = grad_out.contiguous();
  const std::int64_t n = pos.size(0);
  at::Tensor grad_table = at::zeros({grid.levels, grid.table_size, grid.features}, g.options());
  if (n == 0) return grad_table;
  const auto stream = c10::cuda::getCurrentCUDAStream();
  BackwardKernel<<<Blocks(n * grid.levels), kThreads, 0, stream>>>(pos.data_ptr<float>(), g.data_ptr<float>(),
                                                                   grad_table.data_ptr<float>(), n, grid);
  C10_CUDA_KERNEL_LAUNCH_CHECK();
  return grad_table;
}

}  // namespace nerfreg
