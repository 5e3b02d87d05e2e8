#include "nerfreg/reg/transformer.h"

#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

namespace nn = torch::nn;

// Attention on unbatched [L, d] sequences through the (L, N, E) interface.
torch::Tensor Attend(nn::MultiheadAttention& attn, const torch::Tensor& q, const torch::Tensor& k,
                     const torch::Tensor& v) {
  return std::get<0>(attn->forward(q.unsqueeze(1), k.unsqueeze(1), v.unsqueeze(1), {}, /*need_weights=*/false))
      .squeeze(1);
}

void CheckCloud(const torch::Tensor& x, const torch::Tensor& pe, int64_t d, const char* name) {
  TORCH_CHECK(x.dim() == 2 && x.size(1) == d && x.size(0) >= 1, "CrossTransformer: ", name, " must be [M >= 1, ", d,
              "], got ", x.sizes());
  TORCH_CHECK(pe.sizes() == x.sizes(), "CrossTransformer: ", name, " positional encoding must match its features");
}

}  // namespace

bool CrossTransformerOptions::Check() const {
  if (d_model < 1 || heads < 1 || layers < 1 || ffn < 1) {
    LOG_ERROR("CrossTransformerOptions: d_model, heads, layers, ffn must be >= 1");
    return false;
  }
  if (d_model % heads != 0) {
    LOG_ERROR("CrossTransformerOptions: d_model {} is not divisible by heads {}", d_model, heads);
    return false;
  }
  return true;
}

CrossEncoderLayerImpl::CrossEncoderLayerImpl(int64_t d_model, int64_t heads, int64_t ffn) {
  self_attn_ = register_module("self_attn", nn::MultiheadAttention(nn::MultiheadAttentionOptions(d_model, heads)));
  cross_attn_ = register_module("cross_attn", nn::MultiheadAttention(nn::MultiheadAttentionOptions(d_model, heads)));
  norm_self_ = register_module("norm_self", nn::LayerNorm(nn::LayerNormOptions({d_model})));
  norm_cross_ = register_module("norm_cross", nn::LayerNorm(nn::LayerNormOptions({d_model})));
  norm_ffn_ = register_module("norm_ffn", nn::LayerNorm(nn::LayerNormOptions({d_model})));
  ffn1_ = register_module("ffn1", nn::Linear(d_model, ffn));
  ffn2_ = register_module("ffn2", nn::Linear(ffn, d_model));
}

torch::Tensor CrossEncoderLayerImpl::SelfBlock(const torch::Tensor& x, const torch::Tensor& pe) {
  const torch::Tensor h = norm_self_->forward(x) + pe;
  return x + Attend(self_attn_, h, h, h);
}

torch::Tensor CrossEncoderLayerImpl::FfnBlock(const torch::Tensor& x) {
  return x + ffn2_->forward(torch::relu(ffn1_->forward(norm_ffn_->forward(x))));
}

std::pair<torch::Tensor, torch::Tensor> CrossEncoderLayerImpl::forward(const torch::Tensor& src,
                                                                       const torch::Tensor& tgt,
                                                                       const torch::Tensor& src_pe,
                                                                       const torch::Tensor& tgt_pe) {
  torch::Tensor s = SelfBlock(src, src_pe);
  torch::Tensor t = SelfBlock(tgt, tgt_pe);
  // Both directions read the same normalised inputs (simultaneous update).
  const torch::Tensor hs = norm_cross_->forward(s) + src_pe;
  const torch::Tensor ht = norm_cross_->forward(t) + tgt_pe;
  s = s + Attend(cross_attn_, hs, ht, ht);
  t = t + Attend(cross_attn_, ht, hs, hs);
  return {FfnBlock(s), FfnBlock(t)};
}

CrossTransformerImpl::CrossTransformerImpl(const CrossTransformerOptions& options) : options_(options) {
  TORCH_CHECK(options_.Check(), "CrossTransformer: invalid options");
  for (int64_t i = 0; i < options_.layers; ++i) {
    layers_.push_back(register_module("layer" + std::to_string(i),
                                      CrossEncoderLayer(options_.d_model, options_.heads, options_.ffn)));
  }
  final_norm_ = register_module("final_norm", nn::LayerNorm(nn::LayerNormOptions({options_.d_model})));
}

CrossTransformerOutput CrossTransformerImpl::forward(const torch::Tensor& src, const torch::Tensor& tgt,
                                                     const torch::Tensor& src_pe, const torch::Tensor& tgt_pe) {
  CheckCloud(src, src_pe, options_.d_model, "src");
  CheckCloud(tgt, tgt_pe, options_.d_model, "tgt");
  CrossTransformerOutput out;
  torch::Tensor s = src, t = tgt;
  for (auto& layer : layers_) {
    std::tie(s, t) = layer->forward(s, t, src_pe, tgt_pe);
    out.src.push_back(final_norm_->forward(s));
    out.tgt.push_back(final_norm_->forward(t));
  }
  return out;
}

}  // namespace nerfreg
