#pragma once
// Multiresolution hash encoding (Mueller et al. 2022, instant-NGP) for points in [0, 1]^3.
//
// Level l has resolution N_l = floor(base * s^l); a point's 8 surrounding grid vertices are
// looked up in that level's table of T entries x F features (directly when (N_l + 1)^3 <= T,
// else by the spatial hash x*1 ^ y*2654435761 ^ z*805459861 mod T) and interpolated trilinearly.
// Output: [N, L * F], level-major.
//
// Two level layouts (HashEncodingOptions::grid_rule):
//  - "nerfreg": N_l = floor(base * s^l), position scale N_l - 1, dense when (N_l + 1)^3 <= T with
//    stride N_l + 1. What `nerf train` uses.
//  - "instant-ngp": tiny-cuda-nn's rule, so an imported snapshot's table reproduces exactly:
//    scale_l = 2^(l log2 s) * base - 1 (float), N_l = ceil(scale_l) + 1, the level's table has
//    R_l = min(round8(N_l^3), T) rows (stored in the first R_l rows of its [T, F] slice), dense
//    when N_l^3 <= R_l with stride N_l and index mod R_l (it wraps at the upper faces).
//
// Two implementations with one contract:
//  - HashEncode(): a fused C++ kernel (OpenMP over points forward; over levels backward, so each
//    thread owns a level's table slice and gradient scatters need no atomics), wrapped as a torch
//    autograd Function. Gradients flow to the table only (positions are data, not parameters).
//  - HashEncodeReference(): plain torch ops (index_select + products), for tests and benchmarks.
#include <torch/torch.h>

#include <cstdint>
#include <string>

namespace nerfreg {

struct HashEncodingOptions {
  int levels = 16;                              // L
  int features = 2;                             // F per level
  int log2_table_size = 19;                     // T = 2^19 entries per level
  int base_resolution = 16;                     // N_0
  double per_level_scale = 1.4472692012786865;  // s; 16 * s^15 = 4096 (instant-NGP / DReg-NeRF)
  std::string grid_rule = "nerfreg";            // level layout: "nerfreg" or "instant-ngp" (above)
  void Check() const;                           // throws std::invalid_argument
  int OutputDim() const { return levels * features; }
  std::int64_t TableSize() const { return std::int64_t(1) << log2_table_size; }
};

// Per-level resolution (vertices per axis under the options' grid rule).
int LevelResolution(const HashEncodingOptions& options, int level);

// positions: [N, 3] float32 in [0, 1] (clamped), on the table's device: the CPU kernel, the CUDA
// kernel (hash_encoding.cu, CUDA build only), else the reference. table: [L, T, F] float32,
// requires grad. Returns [N, L * F] float32.
torch::Tensor HashEncode(const torch::Tensor& positions, const torch::Tensor& table,
                         const HashEncodingOptions& options);
// Whether HashEncode() runs a fused kernel on `device` (CPU always; CUDA in the CUDA build).
bool HashEncodeHasKernel(const torch::Device& device);
torch::Tensor HashEncodeReference(const torch::Tensor& positions, const torch::Tensor& table,
                                  const HashEncodingOptions& options);

// Initial table: uniform in [-1e-4, 1e-4] as in instant-NGP.
torch::Tensor InitHashTable(const HashEncodingOptions& options, torch::Generator generator = {});

}  // namespace nerfreg
