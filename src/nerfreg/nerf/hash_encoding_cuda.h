#pragma once
// The CUDA side of HashEncode() (hash_encoding.cu, compiled only in the CUDA build): the level
// layout as plain data, so the kernels index exactly as the CPU kernel and the reference do.
#include <ATen/ATen.h>

#include <cstdint>

namespace nerfreg {

constexpr int kMaxHashLevels = 32;  // HashEncodingOptions::Check()'s bound

struct HashLevelParams {
  std::int32_t dense;  // index x + y * stride + z * stride^2, else the spatial hash
  float scale;         // position scale: p * scale + 0.5
  std::uint32_t stride;
  std::int32_t wrap;  // dense index mod rows (instant-ngp), else & mask
  std::uint32_t rows;
};

struct HashGridParams {
  HashLevelParams level[kMaxHashLevels];
  std::int32_t levels = 0;      // L
  std::int32_t features = 0;    // F (<= 8)
  std::uint32_t mask = 0;       // T - 1
  std::int64_t table_size = 0;  // T
};

// positions: [N, 3] float32 CUDA, contiguous; table: [L, T, F] float32 on the same device.
// Returns [N, L * F].
at::Tensor HashEncodeForwardCuda(const at::Tensor& positions, const at::Tensor& table, const HashGridParams& grid);
// grad_out: [N, L * F]. Returns d loss / d table: [L, T, F] (atomic scatters).
at::Tensor HashEncodeBackwardCuda(const at::Tensor& positions, const at::Tensor& grad_out, const HashGridParams& grid);

}  // namespace nerfreg
