#include "nerfreg/dbarf/ibrnet.h"

#include <cmath>

#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

namespace nn = torch::nn;
namespace F = torch::nn::functional;

constexpr int64_t kBaseWidth = 32;   // base_fc output / vis_fc width
constexpr int64_t kModelWidth = 16;  // geometry_fc output, transformer d_model

nn::Linear Linear(int64_t in, int64_t out, bool bias = true) {
  return nn::Linear(nn::LinearOptions(in, out).bias(bias));
}

// Weighted mean and variance over views (dim 2) of x [R,S,V,C] with weights [R,S,V,1].
std::pair<torch::Tensor, torch::Tensor> FusedMeanVariance(const torch::Tensor& x, const torch::Tensor& weight) {
  const torch::Tensor mean = (x * weight).sum(2, true);
  const torch::Tensor var = (weight * (x - mean).pow(2)).sum(2, true);
  return {mean, var};
}

}  // namespace

IbrNetOptions IbrNetOptions::Paper() { return {}; }

IbrNetOptions IbrNetOptions::Cpu() {
  IbrNetOptions o;
  o.feature_channels = 16;
  return o;
}

bool IbrNetOptions::Check() const {
  if (feature_channels < 1) {
    LOG_ERROR("IbrNetOptions: feature_channels must be >= 1");
    return false;
  }
  if (attention_heads < 1 || kModelWidth % attention_heads != 0) {
    LOG_ERROR("IbrNetOptions: attention_heads must divide {}, got {}", kModelWidth, attention_heads);
    return false;
  }
  return true;
}

torch::Tensor SamplePositionalEncoding(int64_t num_samples, int64_t dim) {
  TORCH_CHECK(num_samples >= 1 && dim >= 1, "SamplePositionalEncoding: sizes must be >= 1");
  const torch::Tensor pos = torch::arange(num_samples, torch::kDouble).unsqueeze(1);
  const torch::Tensor j = torch::arange(dim, torch::kLong);
  const torch::Tensor exponent = (j.div(2, "floor") * 2).to(torch::kDouble) / dim;
  const torch::Tensor angle = pos / torch::pow(10000.0, exponent).unsqueeze(0);
  const torch::Tensor even = (j.remainder(2) == 0).unsqueeze(0);
  return torch::where(even, angle.sin(), angle.cos()).to(torch::kFloat);
}

IbrNetImpl::IbrNetImpl(const IbrNetOptions& options) : options_(options) {
  TORCH_CHECK(options_.Check(), "IbrNet: invalid options");
  const int64_t view_ch = 3 + options_.feature_channels;
  s = register_parameter("s", torch::tensor(options_.anti_alias_init, torch::kFloat), options_.anti_alias_pooling);
  ray_dir_fc_ = register_module("ray_dir_fc", nn::Sequential(Linear(4, 16), nn::ELU(), Linear(16, view_ch), nn::ELU()));
  base_fc_ =
      register_module("base_fc", nn::Sequential(Linear(3 * view_ch, 64), nn::ELU(), Linear(64, kBaseWidth), nn::ELU()));
  vis_fc_ = register_module("vis_fc", nn::Sequential(Linear(kBaseWidth, kBaseWidth), nn::ELU(),
                                                     Linear(kBaseWidth, kBaseWidth + 1), nn::ELU()));
  vis_fc2_ = register_module(
      "vis_fc2", nn::Sequential(Linear(kBaseWidth, kBaseWidth), nn::ELU(), Linear(kBaseWidth, 1), nn::Sigmoid()));
  geometry_fc_ = register_module(
      "geometry_fc", nn::Sequential(Linear(2 * kBaseWidth + 1, 64), nn::ELU(), Linear(64, kModelWidth), nn::ELU()));
  out_geometry_fc_ =
      register_module("out_geometry_fc", nn::Sequential(Linear(kModelWidth, 16), nn::ELU(), Linear(16, 1), nn::ReLU()));
  rgb_fc_ = register_module(
      "rgb_fc", nn::Sequential(Linear(kBaseWidth + 1 + 4, 16), nn::ELU(), Linear(16, 8), nn::ELU(), Linear(8, 1)));
  // Kaiming-normal weights, zero biases, on the MLPs the original initialises so; ray_dir_fc,
  // out_geometry_fc and the attention keep torch's default initialisation, as there.
  for (auto* seq : {&base_fc_, &vis_fc_, &vis_fc2_, &geometry_fc_, &rgb_fc_}) {
    for (auto& module : (*seq)->modules(/*include_self=*/false)) {
      if (auto* linear = module->as<nn::Linear>()) {
        torch::NoGradGuard no_grad;
        nn::init::kaiming_normal_(linear->weight);
        nn::init::zeros_(linear->bias);
      }
    }
  }
  w_q_ = register_module("w_q", Linear(kModelWidth, kModelWidth, false));
  w_k_ = register_module("w_k", Linear(kModelWidth, kModelWidth, false));
  w_v_ = register_module("w_v", Linear(kModelWidth, kModelWidth, false));
  w_o_ = register_module("w_o", Linear(kModelWidth, kModelWidth, false));
  attention_norm_ = register_module("attention_norm", nn::LayerNorm(nn::LayerNormOptions({kModelWidth}).eps(1e-6)));
}

torch::Tensor IbrNetImpl::PoolingWeights(const torch::Tensor& ray_diff, const torch::Tensor& mask) {
  const torch::Tensor m = mask.to(torch::kFloat).unsqueeze(-1);  // [R,S,V,1]
  if (!options_.anti_alias_pooling) return m / (m.sum(2, true) + 1e-8);
  const torch::Tensor dot = ray_diff.narrow(-1, 3, 1);
  const torch::Tensor e = torch::exp(s.abs() * (dot - 1.0));
  const torch::Tensor w = (e - std::get<0>(e.min(2, true))) * m;
  return w / (w.sum(2, true) + 1e-8);
}

IbrNetOutput IbrNetImpl::forward(const torch::Tensor& rgb_feat, const torch::Tensor& ray_diff,
                                 const torch::Tensor& mask) {
  const int64_t view_ch = 3 + options_.feature_channels;
  TORCH_CHECK(rgb_feat.dim() == 4 && rgb_feat.size(3) == view_ch && rgb_feat.scalar_type() == torch::kFloat,
              "IbrNet: rgb_feat must be float32 [R,S,V,", view_ch, "], got ", rgb_feat.sizes());
  const int64_t r = rgb_feat.size(0), n = rgb_feat.size(1), v = rgb_feat.size(2);
  TORCH_CHECK(ray_diff.sizes() == torch::IntArrayRef({r, n, v, 4}),
              "IbrNet: ray_diff must be [R,S,V,4] = ", rgb_feat.sizes().slice(0, 3), ", got ", ray_diff.sizes());
  TORCH_CHECK(mask.sizes() == rgb_feat.sizes().slice(0, 3) && mask.scalar_type() == torch::kBool,
              "IbrNet: mask must be bool [R,S,V], got ", mask.sizes());
  const torch::Tensor m = mask.to(torch::kFloat).unsqueeze(-1);  // [R,S,V,1]
  const torch::Tensor rgb_in = rgb_feat.narrow(3, 0, 3);
  const torch::Tensor f = rgb_feat + ray_dir_fc_->forward(ray_diff);

  torch::Tensor weight = PoolingWeights(ray_diff, mask);
  auto [mean, var] = FusedMeanVariance(f, weight);  // [R,S,1,view_ch]
  // base_fc on cat(mean, var, f) per view, with its first layer split by input: the mean / variance
  // part is the same for every view of a sample, so it is applied once per sample and broadcast
  // (a quarter of a rendered view's multiply-adds, and no [R,S,V,3 view_ch] copy).
  const auto* first = base_fc_->ptr(0)->as<nn::Linear>();
  const torch::Tensor w = first->weight;  // [64, 3 view_ch]: (mean, var, f) columns
  torch::Tensor x = F::linear(torch::cat({mean, var}, -1), w.narrow(1, 0, 2 * view_ch), first->bias) +
                    F::linear(f, w.narrow(1, 2 * view_ch, view_ch));  // [R,S,V,64]
  for (auto layer = std::next(base_fc_->begin()); layer != base_fc_->end(); ++layer) x = layer->forward(x);

  const torch::Tensor x_vis = vis_fc_->forward(x * weight);
  const torch::Tensor vis_logit = x_vis.narrow(3, kBaseWidth, 1);
  x = x + x_vis.narrow(3, 0, kBaseWidth);
  torch::Tensor vis = torch::sigmoid(vis_logit) * m;
  vis = vis_fc2_->forward(x * vis) * m;
  weight = vis / (vis.sum(2, true) + 1e-8);

  std::tie(mean, var) = FusedMeanVariance(x, weight);
  torch::Tensor g =
      geometry_fc_->forward(torch::cat({mean.squeeze(2), var.squeeze(2), weight.mean(2)}, -1));  // [R,S,16]
  g = g + SamplePositionalEncoding(n, kModelWidth).to(g.device()).unsqueeze(0);

  // Ray transformer: samples of a ray attend to samples with >= 2 valid views.
  const torch::Tensor num_valid = mask.sum(2);  // [R,S] int64
  const int64_t heads = options_.attention_heads, dk = kModelWidth / heads;
  auto split = [&](const torch::Tensor& t) {
    return t.view({r, n, heads, dk}).transpose(1, 2);  // [R,H,S,dk]
  };
  const torch::Tensor q = split(w_q_->forward(g)), k = split(w_k_->forward(g)), val = split(w_v_->forward(g));
  torch::Tensor logits = torch::matmul(q / std::sqrt(static_cast<double>(dk)), k.transpose(2, 3));
  logits = logits.masked_fill((num_valid < 2).view({r, 1, 1, n}), -1e9);
  const torch::Tensor attended =
      torch::matmul(torch::softmax(logits, -1), val).transpose(1, 2).reshape({r, n, kModelWidth});
  g = attention_norm_->forward(w_o_->forward(attended) + g);

  IbrNetOutput out;
  out.sigma = out_geometry_fc_->forward(g).squeeze(-1).masked_fill(num_valid < 1, 0.0);

  torch::Tensor blend = rgb_fc_->forward(torch::cat({x, vis, ray_diff}, -1));  // [R,S,V,1]
  blend = torch::softmax(blend.masked_fill(~mask.unsqueeze(-1), -1e9), 2);
  out.rgb = (rgb_in * blend).sum(2);
  return out;
}

}  // namespace nerfreg
