// The cross-encoder transformer of DReg-NeRF (spec 4, REGTR's "TransformerCrossEncoder"): each
// layer runs one shared self-attention on each cloud, then one shared cross-attention where each
// cloud attends to the other, then a shared ReLU FFN; pre-norm residual blocks. The positional
// encoding is added to the queries, keys AND values of both attentions (REGTR's
// sa_val_has_pos_emb / ca_val_has_pos_emb). After every layer a final shared LayerNorm gives that
// layer's output; all layers' outputs are returned because every layer is decoded and supervised.
// No dropout (single-pair batches; the original trains with dropout 0).
//
// Clouds are unbatched: [M, d] per cloud (batch 1 pair, as in the paper). Internally
// torch::nn::MultiheadAttention takes (L, N=1, E).
#pragma once

#include <torch/torch.h>

#include <vector>

namespace nerfreg {

struct CrossTransformerOptions {
  // Feature width d (paper 256); divisible by heads.
  int64_t d_model = 256;
  // Attention heads (paper 8).
  int64_t heads = 8;
  // Encoder layers (paper 6).
  int64_t layers = 6;
  // FFN hidden width (paper 1024).
  int64_t ffn = 1024;

  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

class CrossEncoderLayerImpl : public torch::nn::Module {
 public:
  CrossEncoderLayerImpl(int64_t d_model, int64_t heads, int64_t ffn);
  // src [Ms, d], tgt [Mt, d], src_pe [Ms, d], tgt_pe [Mt, d] float32. Returns the updated
  // (src [Ms, d], tgt [Mt, d]) before the final LayerNorm.
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& src, const torch::Tensor& tgt,
                                                  const torch::Tensor& src_pe, const torch::Tensor& tgt_pe);

 private:
  torch::Tensor SelfBlock(const torch::Tensor& x, const torch::Tensor& pe);
  torch::Tensor FfnBlock(const torch::Tensor& x);
  torch::nn::MultiheadAttention self_attn_{nullptr}, cross_attn_{nullptr};
  torch::nn::LayerNorm norm_self_{nullptr}, norm_cross_{nullptr}, norm_ffn_{nullptr};
  torch::nn::Linear ffn1_{nullptr}, ffn2_{nullptr};
};
TORCH_MODULE(CrossEncoderLayer);

struct CrossTransformerOutput {
  // Per layer (options.layers entries), after the final shared LayerNorm: [Ms, d] and [Mt, d].
  std::vector<torch::Tensor> src;
  std::vector<torch::Tensor> tgt;
};

class CrossTransformerImpl : public torch::nn::Module {
 public:
  explicit CrossTransformerImpl(const CrossTransformerOptions& options);
  // src [Ms, d], tgt [Mt, d], src_pe [Ms, d], tgt_pe [Mt, d] float32, Ms, Mt >= 1.
  CrossTransformerOutput forward(const torch::Tensor& src, const torch::Tensor& tgt, const torch::Tensor& src_pe,
                                 const torch::Tensor& tgt_pe);
  const CrossTransformerOptions& options() const { return options_; }

 private:
  CrossTransformerOptions options_;
  std::vector<CrossEncoderLayer> layers_;
  torch::nn::LayerNorm final_norm_{nullptr};
};
TORCH_MODULE(CrossTransformer);

}  // namespace nerfreg
