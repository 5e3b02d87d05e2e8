#include "nerfreg/dbarf/resunet.h"

#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

namespace nn = torch::nn;
namespace F = torch::nn::functional;

nn::Conv2d ReflectConv(int64_t in, int64_t out, int64_t k, int64_t stride, bool bias) {
  return nn::Conv2d(
      nn::Conv2dOptions(in, out, k).stride(stride).padding(k / 2).bias(bias).padding_mode(torch::kReflect));
}

nn::InstanceNorm2d Norm(int64_t c) {
  return nn::InstanceNorm2d(nn::InstanceNorm2dOptions(c).affine(true).track_running_stats(false));
}

// conv (reflect) -> InstanceNorm -> ELU: the decoder's unit.
nn::Sequential ConvNormElu(int64_t in, int64_t out, int64_t k) {
  return nn::Sequential(ReflectConv(in, out, k, 1, true), Norm(out), nn::ELU());
}

// ResNet BasicBlock: 3x3 (stride) -> norm -> ReLU -> 3x3 -> norm, plus a 1x1 projection of the
// input when the shape changes; ReLU after the sum.
class ResBlockImpl : public nn::Module {
 public:
  ResBlockImpl(int64_t in, int64_t out, int64_t stride) {
    body_ = register_module("body", nn::Sequential(ReflectConv(in, out, 3, stride, false), Norm(out), nn::ReLU(),
                                                   ReflectConv(out, out, 3, 1, false), Norm(out)));
    if (stride != 1 || in != out) {
      shortcut_ = register_module("shortcut", nn::Sequential(ReflectConv(in, out, 1, stride, false), Norm(out)));
    }
  }
  torch::Tensor forward(const torch::Tensor& x) {
    return torch::relu(body_->forward(x) + (shortcut_ ? shortcut_->forward(x) : x));
  }

 private:
  nn::Sequential body_{nullptr}, shortcut_{nullptr};
};
TORCH_MODULE(ResBlock);

torch::Tensor UpsampleTo(const torch::Tensor& x, const torch::Tensor& like) {
  return F::interpolate(x, F::InterpolateFuncOptions()
                               .size(std::vector<int64_t>{like.size(2), like.size(3)})
                               .mode(torch::kBilinear)
                               .align_corners(true));
}

}  // namespace

ResUNetOptions ResUNetOptions::Paper() { return {}; }

ResUNetOptions ResUNetOptions::Cpu() {
  ResUNetOptions o;
  o.stem_channels = 16;
  o.layer_channels = {16, 32, 64};
  o.layer_blocks = {1, 1, 1};
  o.out_channels = 32;
  o.nerf_channels = 16;
  return o;
}

bool ResUNetOptions::Check() const {
  if (in_channels < 1 || stem_channels < 1 || out_channels < 1) {
    LOG_ERROR("ResUNetOptions: channel counts must be >= 1");
    return false;
  }
  if (layer_channels.size() != 3 || layer_blocks.size() != 3) {
    LOG_ERROR("ResUNetOptions: layer_channels and layer_blocks must have 3 entries (layers 1-3)");
    return false;
  }
  for (size_t i = 0; i < 3; ++i) {
    if (layer_channels[i] < 1 || layer_blocks[i] < 1) {
      LOG_ERROR("ResUNetOptions: layer {} channels/blocks must be >= 1", i + 1);
      return false;
    }
  }
  if (nerf_channels < 1 || nerf_channels > out_channels) {
    LOG_ERROR("ResUNetOptions: nerf_channels must be in [1, out_channels = {}], got {}", out_channels, nerf_channels);
    return false;
  }
  return true;
}

ResUNetImpl::ResUNetImpl(const ResUNetOptions& options) : options_(options) {
  TORCH_CHECK(options_.Check(), "ResUNet: invalid options");
  const auto& c = options_.layer_channels;
  stem_ = register_module("stem", nn::Sequential(ReflectConv(options_.in_channels, options_.stem_channels, 7, 2, false),
                                                 Norm(options_.stem_channels), nn::ReLU()));
  int64_t in = options_.stem_channels;
  for (size_t l = 0; l < 3; ++l) {
    nn::Sequential layer;
    for (int64_t b = 0; b < options_.layer_blocks[l]; ++b) {
      layer->push_back(ResBlock(in, c[l], b == 0 ? 2 : 1));
      in = c[l];
    }
    layers_.push_back(register_module("layer" + std::to_string(l + 1), layer));
  }
  up3_ = register_module("up3", ConvNormElu(c[2], c[1], 3));
  fuse3_ = register_module("fuse3", ConvNormElu(2 * c[1], c[1], 3));
  up2_ = register_module("up2", ConvNormElu(c[1], c[0], 3));
  fuse2_ = register_module("fuse2", ConvNormElu(2 * c[0], options_.out_channels, 3));
  out_conv_ =
      register_module("out_conv", nn::Conv2d(nn::Conv2dOptions(options_.out_channels, options_.out_channels, 1)));
}

torch::Tensor ResUNetImpl::forward(const torch::Tensor& images) {
  TORCH_CHECK(images.dim() == 4 && images.size(1) == options_.in_channels, "ResUNet: images must be [V,",
              options_.in_channels, ",H,W], got ", images.sizes());
  TORCH_CHECK(images.scalar_type() == torch::kFloat, "ResUNet: images must be float32");
  TORCH_CHECK(images.size(2) > 16 && images.size(3) > 16, "ResUNet: images must be larger than 16x16, got ",
              images.sizes());
  const torch::Tensor x0 = stem_->forward(images);   // 1/2
  const torch::Tensor x1 = layers_[0]->forward(x0);  // 1/4
  const torch::Tensor x2 = layers_[1]->forward(x1);  // 1/8
  const torch::Tensor x3 = layers_[2]->forward(x2);  // 1/16
  torch::Tensor x = up3_->forward(UpsampleTo(x3, x2));
  x = fuse3_->forward(torch::cat({x2, x}, 1));
  x = up2_->forward(UpsampleTo(x, x1));
  x = fuse2_->forward(torch::cat({x1, x}, 1));
  return out_conv_->forward(x);
}

torch::Tensor ResUNetImpl::NerfFeatures(const torch::Tensor& images) {
  return forward(images).narrow(1, 0, options_.nerf_channels);
}

}  // namespace nerfreg
