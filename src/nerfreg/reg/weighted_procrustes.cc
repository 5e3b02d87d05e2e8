#include "nerfreg/util/torch_device.h"  // torch::linalg under LibTorch 2.x
#include "nerfreg/reg/weighted_procrustes.h"

#include "nerfreg/util/logging.h"

namespace nerfreg {

bool WeightedProcrustesOptions::Check() const {
  if (!(min_weight_sum > 0.0)) {
    LOG_ERROR("WeightedProcrustesOptions.min_weight_sum must be > 0, got {}", min_weight_sum);
    return false;
  }
  if (!(regularizer >= 0.0)) {
    LOG_ERROR("WeightedProcrustesOptions.regularizer must be >= 0, got {}", regularizer);
    return false;
  }
  return true;
}

WeightedProcrustesResult WeightedProcrustes(const torch::Tensor& x_in_src, const torch::Tensor& x_in_tgt,
                                            const torch::Tensor& weights, const WeightedProcrustesOptions& options) {
  TORCH_CHECK(options.Check(), "WeightedProcrustes: invalid options");
  const bool batched = x_in_src.dim() == 3;
  TORCH_CHECK((x_in_src.dim() == 2 || batched) && x_in_src.size(-1) == 3,
              "WeightedProcrustes: x_in_src must be [B,N,3] or [N,3], got ", x_in_src.sizes());
  TORCH_CHECK(x_in_tgt.sizes() == x_in_src.sizes(), "WeightedProcrustes: x_in_tgt ", x_in_tgt.sizes(), " != x_in_src ",
              x_in_src.sizes());
  TORCH_CHECK(weights.dim() == x_in_src.dim() - 1 && weights.sizes() == x_in_src.sizes().slice(0, x_in_src.dim() - 1),
              "WeightedProcrustes: weights must be ", x_in_src.sizes().slice(0, x_in_src.dim() - 1), ", got ",
              weights.sizes());
  TORCH_CHECK(x_in_src.scalar_type() == torch::kFloat || x_in_src.scalar_type() == torch::kDouble,
              "WeightedProcrustes: float32 or float64 expected");
  TORCH_CHECK(x_in_tgt.scalar_type() == x_in_src.scalar_type() && weights.scalar_type() == x_in_src.scalar_type(),
              "WeightedProcrustes: dtypes differ");
  TORCH_CHECK(x_in_src.size(-2) >= 1, "WeightedProcrustes: no correspondences");

  const torch::Tensor src = batched ? x_in_src : x_in_src.unsqueeze(0);  // [B,N,3]
  const torch::Tensor tgt = batched ? x_in_tgt : x_in_tgt.unsqueeze(0);  // [B,N,3]
  torch::Tensor w = batched ? weights : weights.unsqueeze(0);            // [B,N]
  const int64_t n = src.size(1);
  const auto opts = src.options();

  // Degenerate elements solve with uniform weights (finite everywhere) and are replaced by
  // identity afterwards; torch::where then gives them zero gradient.
  w = w.clamp_min(0.0);
  const torch::Tensor w_sum = w.sum(1, /*keepdim=*/true);                  // [B,1]
  const torch::Tensor valid = w_sum.squeeze(1) >= options.min_weight_sum;  // [B]
  const torch::Tensor valid_bn = valid.unsqueeze(1);
  const torch::Tensor w_safe = torch::where(valid_bn, w, torch::ones_like(w));
  const torch::Tensor w_norm = w_safe / torch::where(valid_bn, w_sum, torch::full_like(w_sum, static_cast<double>(n)));
  const torch::Tensor wn = w_norm.unsqueeze(2);  // [B,N,1]

  const torch::Tensor src_mean = (wn * src).sum(1, true);  // [B,1,3]
  const torch::Tensor tgt_mean = (wn * tgt).sum(1, true);  // [B,1,3]
  const torch::Tensor src_c = src - src_mean;
  const torch::Tensor tgt_c = tgt - tgt_mean;
  // H = sum_i w_i src_c_i tgt_c_i^T, [B,3,3].
  torch::Tensor h = torch::matmul((wn * src_c).transpose(1, 2), tgt_c);
  if (options.regularizer > 0.0) {
    const torch::Tensor diag = torch::tensor({3.0, 2.0, 1.0}, opts).diag();  // [3,3]
    const torch::Tensor mag = 1.0 + h.detach().abs().amax({1, 2}, true);     // [B,1,1]
    h = h + options.regularizer * mag * diag;
  }
  auto [u, s, vh] = torch::linalg::svd(h, /*full_matrices=*/false, c10::nullopt);
  const torch::Tensor v = vh.transpose(1, 2);
  const torch::Tensor ut = u.transpose(1, 2);
  // Reflection fix: D = diag(1, 1, sign(det(V U^T))).
  const torch::Tensor det = torch::linalg::det(torch::matmul(v, ut).detach());  // [B]
  const torch::Tensor d_last = torch::where(det < 0, -torch::ones_like(det), torch::ones_like(det));
  const torch::Tensor d = torch::stack({torch::ones_like(d_last), torch::ones_like(d_last), d_last}, 1);
  torch::Tensor rotation = torch::matmul(v * d.unsqueeze(1), ut);  // V D U^T, [B,3,3]

  torch::Tensor scale = torch::ones({src.size(0)}, opts);
  if (options.estimate_scale) {
    const torch::Tensor src_var = (wn * src_c.pow(2)).sum({1, 2});  // [B]
    const torch::Tensor trace_sd = (s * d).sum(1);                  // [B]
    const torch::Tensor src_var_safe = src_var.clamp_min(1e-12);
    const torch::Tensor scale_ok = valid & (src_var > 1e-12);
    scale = torch::where(scale_ok, trace_sd / src_var_safe, torch::ones_like(trace_sd));
  }
  torch::Tensor translation =
      tgt_mean.squeeze(1) - scale.unsqueeze(1) * torch::matmul(rotation, src_mean.transpose(1, 2)).squeeze(2);  // [B,3]

  const torch::Tensor eye = torch::eye(3, opts).expand_as(rotation);
  rotation = torch::where(valid.view({-1, 1, 1}), rotation, eye);
  translation = torch::where(valid_bn, translation, torch::zeros_like(translation));
  scale = torch::where(valid, scale, torch::ones_like(scale));

  WeightedProcrustesResult result;
  result.rotation = batched ? rotation : rotation.squeeze(0);
  result.translation = batched ? translation : translation.squeeze(0);
  result.scale = batched ? scale : scale.squeeze(0);
  result.valid = batched ? valid : valid.squeeze(0);
  return result;
}

}  // namespace nerfreg
