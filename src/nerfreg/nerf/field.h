#pragma once
// The NeRF block's radiance field (instant-NGP as DReg-NeRF trains it, spec dreg-nerf.md 2):
// hash encoding of the position normalised to the AABB -> density MLP (1 hidden layer, 16 outputs;
// density = trunc_exp(out0 - 1)) ; SH degree 4 of the view direction + the other 15 outputs ->
// colour MLP (2 hidden layers, sigmoid). MLPs without biases, as tiny-cuda-nn's fully fused MLP.
//
// flavor "instant-ngp" reproduces an imported instant-ngp snapshot (nerf/ngp_import.h) in the
// block's own frame: the encoding uses tiny-cuda-nn's level rule; the normalised position and the
// view direction are permuted by `axis_order` before encoding (ngp cycles xyz <- yzx); density =
// exp(out0) * density_scale (ngp's exponential activation, times the world-to-ngp length scale);
// the colour MLP takes all density outputs, out0 included, then the 16 SH (ngp's order).
#include <torch/torch.h>

#include "nerfreg/nerf/hash_encoding.h"

namespace nerfreg {

struct FieldOptions {
  HashEncodingOptions encoding;
  int hidden_dim = 64;       // width of both MLPs
  int geo_feature_dim = 15;  // density MLP outputs besides density
  int color_hidden_layers = 2;
  // Axis-aligned box the field lives in (world units of the block); outside, density is 0.
  std::vector<double> aabb_min = {-1.5, -1.5, -1.5};
  std::vector<double> aabb_max = {1.5, 1.5, 1.5};
  // Use the torch-ops reference kernels (encoding here, compositing in the trainer) instead of
  // the fused ones: for tests and benchmarks only, not saved in checkpoints.
  bool reference_kernels = false;
  // "nerfreg" (what `nerf train` makes) or "instant-ngp" (above; requires encoding.grid_rule
  // "instant-ngp"). Checkpoints without these fields load as "nerfreg".
  std::string flavor = "nerfreg";
  // instant-ngp: encoder axis k reads block axis axis_order[k] (positions and directions).
  std::vector<int> axis_order = {0, 1, 2};
  // instant-ngp: sigma = exp(out0) * density_scale (block lengths are 1/density_scale of ngp's).
  double density_scale = 1.0;
  bool InstantNgp() const { return flavor == "instant-ngp"; }
  void Check() const;  // throws std::invalid_argument
};

// exp() whose gradient is clamped (exp(min(x, 15))) so early training cannot blow up.
torch::Tensor TruncExp(const torch::Tensor& x);

// Real spherical harmonics up to degree 3 (16 coefficients) of unit directions [N, 3] -> [N, 16],
// in tiny-cuda-nn's ordering and constants.
torch::Tensor SphericalHarmonics16(const torch::Tensor& dirs);

class NerfFieldImpl : public torch::nn::Module {
 public:
  explicit NerfFieldImpl(const FieldOptions& options);

  // positions [N, 3] world (float32), dirs [N, 3] unit -> sigma [N], rgb [N, 3]. Inputs on the
  // field's device (module->to(device)) stay there; inputs on another device are copied to it and
  // the outputs back to the positions' device.
  std::pair<torch::Tensor, torch::Tensor> Forward(const torch::Tensor& positions, const torch::Tensor& dirs);
  // Density only: positions [N, 3] -> sigma [N] (0 outside the AABB).
  torch::Tensor Density(const torch::Tensor& positions);
  // The colour of each position seen along each of a few directions: positions [N, 3], dirs
  // [D, 3] unit -> rgb [N, D, 3], row (n, d) as Forward(positions[n], dirs[d]) gives it. The hash
  // encoding and the density MLP run once per position (they do not depend on the direction),
  // only the colour MLP once per pair. On the field's device.
  torch::Tensor ColorsAlong(const torch::Tensor& positions, const torch::Tensor& dirs);

  const FieldOptions& options() const { return options_; }
  torch::Tensor table;  // [L, T, F] hash table parameters

 private:
  // Returns sigma [N] and the geometry features [N, geo_feature_dim].
  std::pair<torch::Tensor, torch::Tensor> DensityAndFeatures(const torch::Tensor& positions);

  FieldOptions options_;
  torch::Tensor aabb_min_, aabb_size_;  // [3] buffers
  torch::Tensor axes_;                  // [3] int64 axis_order (instant-ngp flavor)
  torch::nn::Sequential density_mlp_{nullptr}, color_mlp_{nullptr};
};
TORCH_MODULE(NerfField);

}  // namespace nerfreg
