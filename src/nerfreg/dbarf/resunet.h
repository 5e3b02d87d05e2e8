// The image feature extractor of IBRNet as DBARF uses it (spec dbarf.md 2, "ResUNet"): a
// ResNet-34-style encoder (BasicBlocks, layers 1-3, each stride 2, no maxpool) and a U-Net decoder
// with skips, producing a feature map at 1/4 of the image resolution. Every source image goes
// through it once per rendered batch; the NeRF aggregation (ibrnet.h) samples the first
// `nerf_channels` channels at the projections of its 3D samples.
//
// Normalisation is InstanceNorm (affine, no running statistics), so train and eval behave the same
// and a batch of V source views is V independent images. Convolutions pad by reflection.
// Upsampling is bilinear with align_corners (as the original); the upsampled map is resized to the
// skip's exact size, so image sizes that are not multiples of 16 work (the original pads instead).
// The skip comes first in each concatenation, as in the original.
#pragma once

#include <torch/torch.h>

#include <vector>

namespace nerfreg {

struct ResUNetOptions {
  // Input channels (RGB in [0, 1]).
  int64_t in_channels = 3;
  // Stem conv (7x7, stride 2) output channels; paper 64.
  int64_t stem_channels = 64;
  // Output channels of encoder layers 1-3 (each starts with a stride-2 BasicBlock); paper
  // 64, 128, 256. The decoder mirrors them: up 3 -> 2 is layer_channels[1] wide, up 2 -> 1 is
  // layer_channels[0] wide.
  std::vector<int64_t> layer_channels = {64, 128, 256};
  // BasicBlocks per encoder layer; paper ResNet-34 {3, 4, 6}.
  std::vector<int64_t> layer_blocks = {3, 4, 6};
  // Channels of the output map (after the final 1x1 conv); paper 64 (coarse 32 + "fine" 32).
  int64_t out_channels = 64;
  // The first `nerf_channels` output channels are what the NeRF sees; paper 32.
  int64_t nerf_channels = 32;

  // The original sizes, and a small CPU configuration (channels / 4, one block per layer).
  static ResUNetOptions Paper();
  static ResUNetOptions Cpu();
  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

class ResUNetImpl : public torch::nn::Module {
 public:
  explicit ResUNetImpl(const ResUNetOptions& options);
  // images: [V, in_channels, H, W] float32, H, W > 16 (layer 3, at 1/16, needs >= 2 pixels).
  // Returns [V, out_channels, h, w] float32 with h = ceil(ceil(H / 2) / 2) (likewise w): the
  // feature map covers the same image extent, 1/4 of the resolution.
  torch::Tensor forward(const torch::Tensor& images);
  // forward() restricted to the first nerf_channels channels: [V, nerf_channels, h, w].
  torch::Tensor NerfFeatures(const torch::Tensor& images);
  const ResUNetOptions& options() const { return options_; }

 private:
  ResUNetOptions options_;
  torch::nn::Sequential stem_{nullptr};
  std::vector<torch::nn::Sequential> layers_;
  torch::nn::Sequential up3_{nullptr}, fuse3_{nullptr}, up2_{nullptr}, fuse2_{nullptr};
  torch::nn::Conv2d out_conv_{nullptr};
};
TORCH_MODULE(ResUNet);

}  // namespace nerfreg
