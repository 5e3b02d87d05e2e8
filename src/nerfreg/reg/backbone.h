// The 3D feature pyramid of DReg-NeRF (spec 4): a 3D ResNet of Bottleneck blocks and a top-down
// FPN, shared by source and target. Input: a dense RGBA grid [B, C_in, D, D, D] (float32);
// output: per-voxel features at the input resolution, gathered at masked voxels.
#pragma once

#include <torch/torch.h>

#include <string>
#include <vector>

namespace nerfreg {

struct BackboneOptions {
  // Input channels of the grid (RGBA = 4).
  int64_t in_channels = 4;
  // Stem output channels (conv k5 s2 -> norm -> ReLU, then maxpool s2). The norm layers
  // normalise each grid by its own statistics (backbone.cc, Norm).
  int64_t stem_channels = 64;
  // Bottleneck width per stage (output = width * 4); paper 64, 128, 256, 512 (-> 256..2048).
  std::vector<int64_t> stage_widths = {64, 128, 256, 512};
  // Bottleneck blocks per stage; paper ResNet-50 {3, 4, 6, 3}.
  std::vector<int64_t> stage_blocks = {3, 4, 6, 3};
  // FPN output channels (the feature dimension d downstream); paper 256.
  int64_t fpn_channels = 256;

  // The original sizes, and a small CPU configuration.
  static BackboneOptions Paper();
  static BackboneOptions Cpu();
  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

class BackboneImpl : public torch::nn::Module {
 public:
  explicit BackboneImpl(const BackboneOptions& options);
  // grid: [B, in_channels, D, H, W] float32, D, H, W divisible by 2^(stages + 1).
  // Returns [B, fpn_channels, D, H, W] float32 (p1 trilinearly upsampled to the input grid).
  torch::Tensor forward(const torch::Tensor& grid);
  // Features at the voxels where mask ([D, H, W] bool) is set, for batch element 0 of a
  // [1, C, D, H, W] grid: [M, fpn_channels], M = mask.sum(), in mask.nonzero() order.
  torch::Tensor ForwardAtMask(const torch::Tensor& grid, const torch::Tensor& mask);
  const BackboneOptions& options() const { return options_; }

 private:
  BackboneOptions options_;
  torch::nn::Sequential stem_{nullptr};
  std::vector<torch::nn::Sequential> stages_;
  std::vector<torch::nn::Conv3d> laterals_;  // 1x1 on c2..c5, 3x3 on c1 (index 0)
  std::vector<torch::nn::Conv3d> smooths_;   // 3x3 after each top-down merge (c1..c4)
};
TORCH_MODULE(Backbone);

}  // namespace nerfreg
