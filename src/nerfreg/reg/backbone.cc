#include "nerfreg/reg/backbone.h"

#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

namespace nn = torch::nn;

nn::Conv3d Conv(int64_t in, int64_t out, int64_t k, int64_t stride = 1) {
  return nn::Conv3d(nn::Conv3dOptions(in, out, k).stride(stride).padding(k / 2).bias(false));
}

// The ResNet's normalisation, per grid: each channel normalised by its own mean and variance over
// the grid's voxels, then the learnt scale and shift, in training and inference alike. With one
// grid per forward pass (batch 1, as the paper trains) that is exactly what BatchNorm computes in
// training; BatchNorm's running averages, which it would use at inference, do not describe any
// one grid (their occupied share and colours differ widely), and with them the first shipped
// weights failed even on their own training pairs (docs/notes/2026-11-23-grids-icp-half-turn.md,
// "Per-grid normalisation"). The parameters keep BatchNorm's names (weight, bias), so weights
// trained with it load; its running averages in such files are not read.
nn::InstanceNorm3d Norm(int64_t channels) {
  return nn::InstanceNorm3d(nn::InstanceNorm3dOptions(channels).affine(true).track_running_stats(false));
}

// ResNet Bottleneck: 1x1 -> 3x3 (stride) -> 1x1 (x4), residual with a projection when needed.
class BottleneckImpl : public nn::Module {
 public:
  BottleneckImpl(int64_t in, int64_t width, int64_t stride) {
    body_ = register_module(
        "body", nn::Sequential(Conv(in, width, 1), Norm(width), nn::ReLU(), Conv(width, width, 3, stride), Norm(width),
                               nn::ReLU(), Conv(width, width * 4, 1), Norm(width * 4)));
    if (stride != 1 || in != width * 4) {
      shortcut_ = register_module("shortcut", nn::Sequential(Conv(in, width * 4, 1, stride), Norm(width * 4)));
    }
  }
  torch::Tensor forward(const torch::Tensor& x) {
    return torch::relu(body_->forward(x) + (shortcut_ ? shortcut_->forward(x) : x));
  }

 private:
  nn::Sequential body_{nullptr}, shortcut_{nullptr};
};
TORCH_MODULE(Bottleneck);

}  // namespace

BackboneOptions BackboneOptions::Paper() { return {}; }

BackboneOptions BackboneOptions::Cpu() {
  BackboneOptions o;
  o.stem_channels = 8;
  // Three stages: a 32^3 grid ends at 2^3 (the per-grid normalisation needs > 1 voxel per channel).
  o.stage_widths = {8, 16, 32};
  o.stage_blocks = {1, 1, 1};
  o.fpn_channels = 32;
  return o;
}

bool BackboneOptions::Check() const {
  if (in_channels < 1 || stem_channels < 1 || fpn_channels < 1) {
    LOG_ERROR("BackboneOptions: channel counts must be >= 1");
    return false;
  }
  if (stage_widths.empty() || stage_widths.size() != stage_blocks.size()) {
    LOG_ERROR("BackboneOptions: stage_widths and stage_blocks must be non-empty, same length");
    return false;
  }
  for (size_t i = 0; i < stage_widths.size(); ++i) {
    if (stage_widths[i] < 1 || stage_blocks[i] < 1) {
      LOG_ERROR("BackboneOptions: stage {} width/blocks must be >= 1", i);
      return false;
    }
  }
  return true;
}

BackboneImpl::BackboneImpl(const BackboneOptions& options) : options_(options) {
  TORCH_CHECK(options_.Check(), "Backbone: invalid options");
  stem_ = register_module("stem", nn::Sequential(Conv(options_.in_channels, options_.stem_channels, 5, 2),
                                                 Norm(options_.stem_channels), nn::ReLU()));
  int64_t in = options_.stem_channels;
  laterals_.push_back(register_module("lateral0", Conv(in, options_.fpn_channels, 3)));
  for (size_t s = 0; s < options_.stage_widths.size(); ++s) {
    nn::Sequential stage;
    const int64_t width = options_.stage_widths[s];
    for (int64_t b = 0; b < options_.stage_blocks[s]; ++b) {
      // Stage 0 follows the maxpool (stride 1); later stages halve the resolution.
      stage->push_back(Bottleneck(in, width, (b == 0 && s > 0) ? 2 : 1));
      in = width * 4;
    }
    stages_.push_back(register_module("stage" + std::to_string(s + 1), stage));
    laterals_.push_back(register_module("lateral" + std::to_string(s + 1), Conv(in, options_.fpn_channels, 1)));
  }
  for (size_t s = 0; s < options_.stage_widths.size(); ++s) {
    smooths_.push_back(
        register_module("smooth" + std::to_string(s), Conv(options_.fpn_channels, options_.fpn_channels, 3)));
  }
}

torch::Tensor BackboneImpl::forward(const torch::Tensor& grid) {
  TORCH_CHECK(grid.dim() == 5 && grid.size(1) == options_.in_channels, "Backbone: grid must be [B,",
              options_.in_channels, ",D,H,W], got ", grid.sizes());
  TORCH_CHECK(grid.scalar_type() == torch::kFloat, "Backbone: grid must be float32");
  const int64_t factor = int64_t{1} << (options_.stage_widths.size() + 1);
  for (int d = 2; d < 5; ++d) {
    TORCH_CHECK(grid.size(d) % factor == 0, "Backbone: grid sizes must be divisible by ", factor, ", got ",
                grid.sizes());
  }
  std::vector<torch::Tensor> c;  // c1 (stem, 1/2) .. c_{S+1}
  c.push_back(stem_->forward(grid));
  torch::Tensor x = torch::max_pool3d(c[0], 3, 2, 1);
  for (auto& stage : stages_) {
    x = stage->forward(x);
    c.push_back(x);
  }
  auto up = [](const torch::Tensor& t, const torch::Tensor& like) {
    return torch::nn::functional::interpolate(
        t, torch::nn::functional::InterpolateFuncOptions()
               .size(std::vector<int64_t>(like.sizes().begin() + 2, like.sizes().end()))
               .mode(torch::kTrilinear)
               .align_corners(false));
  };
  torch::Tensor p = laterals_.back()->forward(c.back());
  for (int64_t k = static_cast<int64_t>(c.size()) - 2; k >= 0; --k) {
    p = smooths_[k]->forward(up(p, c[k]) + laterals_[k]->forward(c[k]));
  }
  return up(p, grid);
}

torch::Tensor BackboneImpl::ForwardAtMask(const torch::Tensor& grid, const torch::Tensor& mask) {
  TORCH_CHECK(grid.dim() == 5 && grid.size(0) == 1, "Backbone: grid must be [1,C,D,H,W]");
  TORCH_CHECK(mask.dim() == 3 && mask.scalar_type() == torch::kBool && mask.sizes() == grid.sizes().slice(2),
              "Backbone: mask must be bool ", grid.sizes().slice(2), ", got ", mask.sizes());
  const torch::Tensor features = forward(grid)[0];      // [C,D,H,W]
  return features.permute({1, 2, 3, 0}).index({mask});  // [M,C]
}

}  // namespace nerfreg
