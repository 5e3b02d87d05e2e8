// IBRNet's aggregation network as DBARF uses it (spec dbarf.md 2, "Projection and aggregation"):
// for every sample of a ray it pools the colours and features the sample projects to in V source
// views into a density, and predicts per-view blending weights for its colour. Coarse only.
//
//   per view: f = [rgb 3, feature C] + ray_dir_fc(ray_diff)              (3 + C channels)
//   anti-alias pooling weights w (exp(|s| (dot - 1)) minus its min over views, masked, normalised)
//   base_fc([weighted mean, weighted var, f]) -> x (32)
//   vis_fc(x * w) -> residual (32) + visibility logit; vis_fc2 -> visibility v in (0, 1), masked
//   geometry_fc([mean, var of x under v, mean of the normalised v]) (16) + sinusoidal PE(sample)
//   ray transformer over the samples (1 layer, 4 heads, d_model 16, masked) -> sigma head (ReLU)
//   colour: rgb_fc([x, v, ray_diff]) per view, softmax over valid views, blend of the source rgb.
//
// Deliberate differences from the original code:
//  - The positional encoding is computed for whatever number of samples S is given (the original
//    hard-codes a 64-row table, spec 9.4).
//  - The transformer masks KEYS (samples with < 2 valid views are not attended to). The original's
//    mask broadcasts over the keys and so only blanks whole query rows, which then average every
//    sample of the ray.
// No dropout (DBARF comments it out). All activations ELU. Linear layers of base_fc, vis_fc,
// vis_fc2, geometry_fc and rgb_fc are Kaiming-normal with zero biases; ray_dir_fc,
// out_geometry_fc and the attention keep torch's defaults (as the original).
#pragma once

#include <torch/torch.h>

namespace nerfreg {

struct IbrNetOptions {
  // Feature channels per view (ResUNetOptions::nerf_channels); paper 32.
  int64_t feature_channels = 32;
  // Anti-alias pooling (learnable sharpness s); false: uniform weights over valid views.
  bool anti_alias_pooling = true;
  // Initial value of the anti-alias sharpness s; paper 0.2.
  double anti_alias_init = 0.2;
  // Attention heads of the ray transformer (d_model 16, d_k = d_v = 16 / heads); paper 4.
  int64_t attention_heads = 4;

  // The original sizes, and a CPU configuration (16 feature channels, to match ResUNet's Cpu()).
  static IbrNetOptions Paper();
  static IbrNetOptions Cpu();
  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

struct IbrNetOutput {
  torch::Tensor rgb;    // [R, S, 3] float32: blended source colour of each sample
  torch::Tensor sigma;  // [R, S] float32 >= 0; exactly 0 where a sample has no valid view
};

// Fixed sinusoidal encoding of sample indices 0..num_samples-1: [num_samples, dim] float32,
// entry (i, j) = sin (j even) or cos (j odd) of i / 10000^(2 floor(j/2) / dim).
torch::Tensor SamplePositionalEncoding(int64_t num_samples, int64_t dim);

class IbrNetImpl : public torch::nn::Module {
 public:
  explicit IbrNetImpl(const IbrNetOptions& options);

  // rgb_feat: [R, S, V, 3 + feature_channels] float32 (sampled source rgb, then features);
  // ray_diff: [R, S, V, 4] float32 (projection.h RayDifference, permuted);
  // mask: [R, S, V] bool (sample projects inside view and in front of it).
  IbrNetOutput forward(const torch::Tensor& rgb_feat, const torch::Tensor& ray_diff, const torch::Tensor& mask);

  // The anti-alias pooling weights [R, S, V, 1]: zero on invalid views, summing to 1 over the
  // valid views (unless all of a sample's weights tie with the minimum, e.g. a single view: then
  // all are 0, as in the original). Uniform over valid views when anti_alias_pooling is false.
  torch::Tensor PoolingWeights(const torch::Tensor& ray_diff, const torch::Tensor& mask);

  const IbrNetOptions& options() const { return options_; }
  torch::Tensor s;  // [] learnable anti-alias sharpness

 private:
  IbrNetOptions options_;
  torch::nn::Sequential ray_dir_fc_{nullptr}, base_fc_{nullptr}, vis_fc_{nullptr}, vis_fc2_{nullptr},
      geometry_fc_{nullptr}, out_geometry_fc_{nullptr}, rgb_fc_{nullptr};
  torch::nn::Linear w_q_{nullptr}, w_k_{nullptr}, w_v_{nullptr}, w_o_{nullptr};
  torch::nn::LayerNorm attention_norm_{nullptr};
};
TORCH_MODULE(IbrNet);

}  // namespace nerfreg
