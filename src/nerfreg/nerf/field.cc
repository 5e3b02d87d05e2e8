#include "nerfreg/nerf/field.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace nerfreg {

void FieldOptions::Check() const {
  encoding.Check();
  if (hidden_dim < 1 || geo_feature_dim < 0 || color_hidden_layers < 1 || aabb_min.size() != 3 ||
      aabb_max.size() != 3) {
    throw std::invalid_argument("FieldOptions: out of range");
  }
  for (int k = 0; k < 3; ++k)
    if (!(aabb_max[k] > aabb_min[k])) throw std::invalid_argument("FieldOptions: aabb_max must exceed aabb_min");
  if (flavor != "nerfreg" && flavor != "instant-ngp")
    throw std::invalid_argument("FieldOptions: flavor must be nerfreg or instant-ngp");
  if ((flavor == "instant-ngp") != (encoding.grid_rule == "instant-ngp")) {
    throw std::invalid_argument(
        "FieldOptions: the instant-ngp flavor goes with the instant-ngp grid rule, and only it");
  }
  auto sorted = axis_order;
  std::sort(sorted.begin(), sorted.end());
  if (sorted != std::vector<int>{0, 1, 2}) throw std::invalid_argument("FieldOptions: axis_order must permute 0, 1, 2");
  if (!InstantNgp() && axis_order != std::vector<int>{0, 1, 2})
    throw std::invalid_argument("FieldOptions: axis_order needs the instant-ngp flavor");
  if (!(density_scale > 0) || !std::isfinite(density_scale))
    throw std::invalid_argument("FieldOptions: density_scale must be positive");
}

namespace {
class TruncExpFunction : public torch::autograd::Function<TruncExpFunction> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, torch::Tensor x) {
    ctx->save_for_backward({x});
    return torch::exp(x);
  }
  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx, torch::autograd::tensor_list g) {
    const auto x = ctx->get_saved_variables()[0];
    return {g[0] * torch::exp(x.clamp_max(15))};
  }
};
}  // namespace

torch::Tensor TruncExp(const torch::Tensor& x) { return TruncExpFunction::apply(x); }

torch::Tensor SphericalHarmonics16(const torch::Tensor& d) {
  TORCH_CHECK(d.dim() == 2 && d.size(1) == 3, "SphericalHarmonics16: dirs must be [N, 3]");
  const auto x = d.select(1, 0), y = d.select(1, 1), z = d.select(1, 2);
  const auto xy = x * y, xz = x * z, yz = y * z, x2 = x * x, y2 = y * y, z2 = z * z;
  return torch::stack({torch::full_like(x, 0.28209479177387814), -0.48860251190291987 * y, 0.48860251190291987 * z,
                       -0.48860251190291987 * x, 1.0925484305920792 * xy, -1.0925484305920792 * yz,
                       0.94617469575755997 * z2 - 0.31539156525251999, -1.0925484305920792 * xz,
                       0.54627421529603959 * x2 - 0.54627421529603959 * y2, 0.59004358992664352 * y * (-3.0 * x2 + y2),
                       2.8906114426405538 * xy * z, 0.45704579946446572 * y * (1.0 - 5.0 * z2),
                       0.3731763325901154 * z * (5.0 * z2 - 3.0), 0.45704579946446572 * x * (1.0 - 5.0 * z2),
                       1.4453057213202769 * z * (x2 - y2), 0.59004358992664352 * x * (-x2 + 3.0 * y2)},
                      1);
}

NerfFieldImpl::NerfFieldImpl(const FieldOptions& options) : options_(options) {
  options_.Check();
  const auto& e = options_.encoding;
  table = register_parameter("table", InitHashTable(e));
  aabb_min_ = register_buffer("aabb_min", torch::tensor(options_.aabb_min, torch::kFloat32));
  aabb_size_ = register_buffer("aabb_size", torch::tensor(options_.aabb_max, torch::kFloat32) - aabb_min_);
  const int h = options_.hidden_dim;
  using torch::nn::Linear;
  using torch::nn::LinearOptions;
  density_mlp_ = register_module(
      "density_mlp", torch::nn::Sequential(Linear(LinearOptions(e.OutputDim(), h).bias(false)), torch::nn::ReLU(),
                                           Linear(LinearOptions(h, 1 + options_.geo_feature_dim).bias(false))));
  torch::nn::Sequential color;
  const int color_inputs = 16 + options_.geo_feature_dim + (options_.InstantNgp() ? 1 : 0);
  color->push_back(Linear(LinearOptions(color_inputs, h).bias(false)));
  color->push_back(torch::nn::ReLU());
  for (int k = 1; k < options_.color_hidden_layers; ++k) {
    color->push_back(Linear(LinearOptions(h, h).bias(false)));
    color->push_back(torch::nn::ReLU());
  }
  color->push_back(Linear(LinearOptions(h, 3).bias(false)));
  color_mlp_ = register_module("color_mlp", color);
  if (options_.InstantNgp()) {
    axes_ = register_buffer(
        "axis_order", torch::tensor(std::vector<std::int64_t>(options_.axis_order.begin(), options_.axis_order.end())));
  }
}

std::pair<torch::Tensor, torch::Tensor> NerfFieldImpl::DensityAndFeatures(const torch::Tensor& positions) {
  TORCH_CHECK(positions.dim() == 2 && positions.size(1) == 3, "NerfField: positions must be [N, 3]");
  auto unit = (positions - aabb_min_) / aabb_size_;
  const auto inside = ((unit >= 0) & (unit <= 1)).all(1);
  if (options_.InstantNgp()) {
    unit = unit.index_select(1, axes_);
    const auto encoded = options_.reference_kernels ? HashEncodeReference(unit, table, options_.encoding)
                                                    : HashEncode(unit.contiguous(), table, options_.encoding);
    const auto h = density_mlp_->forward(encoded);
    const auto sigma = torch::exp(h.select(1, 0)) * options_.density_scale * inside.to(h.dtype());
    return {sigma, h};  // ngp's colour network takes every density output
  }
  const auto encoded = options_.reference_kernels ? HashEncodeReference(unit, table, options_.encoding)
                                                  : HashEncode(unit.contiguous(), table, options_.encoding);
  const auto h = density_mlp_->forward(encoded);
  const auto sigma = TruncExp(h.select(1, 0) - 1.0) * inside.to(h.dtype());
  return {sigma, h.slice(1, 1)};
}

std::pair<torch::Tensor, torch::Tensor> NerfFieldImpl::Forward(const torch::Tensor& positions,
                                                               const torch::Tensor& dirs) {
  const torch::Device device = table.device();
  if (positions.device() != device || dirs.device() != device) {
    // A caller's samples on another device (e.g. CPU points of an export on a GPU field) go to
    // the field's device and the answers come back; the copies are differentiable. The trainer
    // and the renderer hand over samples already on the field's device: no copy.
    auto [sigma, rgb] = Forward(positions.to(device), dirs.to(device));
    return {sigma.to(positions.device()), rgb.to(positions.device())};
  }
  auto [sigma, features] = DensityAndFeatures(positions);
  const auto color_in = options_.InstantNgp()
                            ? torch::cat({features, SphericalHarmonics16(dirs.index_select(1, axes_))}, 1)
                            : torch::cat({SphericalHarmonics16(dirs), features}, 1);
  const auto rgb = torch::sigmoid(color_mlp_->forward(color_in));
  return {sigma, rgb};
}

torch::Tensor NerfFieldImpl::ColorsAlong(const torch::Tensor& positions, const torch::Tensor& dirs) {
  TORCH_CHECK(dirs.dim() == 2 && dirs.size(1) == 3, "NerfField: dirs must be [D, 3]");
  const std::int64_t n = positions.size(0), d = dirs.size(0);
  const auto features = DensityAndFeatures(positions).second;                                        // [N, F]
  const auto sh = SphericalHarmonics16(options_.InstantNgp() ? dirs.index_select(1, axes_) : dirs);  // [D, 16]
  const auto f = features.unsqueeze(1).expand({n, d, features.size(1)});
  const auto s = sh.unsqueeze(0).expand({n, d, 16});
  // The colour MLP's input as Forward builds it, one row per (position, direction).
  const auto color_in = options_.InstantNgp() ? torch::cat({f, s}, 2) : torch::cat({s, f}, 2);  // [N, D, 16 + F]
  return torch::sigmoid(color_mlp_->forward(color_in.reshape({n * d, -1}))).view({n, d, 3});
}

torch::Tensor NerfFieldImpl::Density(const torch::Tensor& positions) {
  const torch::Device device = table.device();
  if (positions.device() != device) return DensityAndFeatures(positions.to(device)).first.to(positions.device());
  return DensityAndFeatures(positions).first;
}

}  // namespace nerfreg
