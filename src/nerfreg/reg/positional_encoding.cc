#include "nerfreg/reg/positional_encoding.h"

#include "nerfreg/util/logging.h"

namespace nerfreg {

bool PositionalEncodingOptions::Check() const {
  if (d_model < 6) {
    LOG_ERROR("PositionalEncodingOptions: d_model must be >= 6, got {}", d_model);
    return false;
  }
  if (!(temperature > 0.0) || !(scale > 0.0)) {
    LOG_ERROR("PositionalEncodingOptions: temperature and scale must be > 0");
    return false;
  }
  return true;
}

torch::Tensor SinePositionalEncoding(const torch::Tensor& xyz, const PositionalEncodingOptions& options) {
  TORCH_CHECK(options.Check(), "SinePositionalEncoding: invalid options");
  TORCH_CHECK(xyz.dim() == 2 && xyz.size(1) == 3, "SinePositionalEncoding: xyz must be [N, 3]");
  TORCH_CHECK(xyz.is_floating_point(), "SinePositionalEncoding: xyz must be floating point");
  const int64_t n = options.FeaturesPerAxis();
  const auto f = torch::TensorOptions().dtype(xyz.dtype()).device(xyz.device());
  const torch::Tensor pair = torch::floor(torch::arange(n, f) / 2.0);  // 0, 0, 1, 1, ...
  const torch::Tensor inv_freq = torch::pow(options.temperature, -2.0 * pair / static_cast<double>(n));
  const torch::Tensor arg = (xyz * options.scale).unsqueeze(-1) * inv_freq;  // [N, 3, n]
  const torch::Tensor even = (torch::arange(n, f.dtype(torch::kLong)) % 2 == 0);
  const torch::Tensor enc = torch::where(even, torch::sin(arg), torch::cos(arg)).reshape({xyz.size(0), 3 * n});
  return torch::constant_pad_nd(enc, {0, options.d_model - 3 * n});
}

}  // namespace nerfreg
