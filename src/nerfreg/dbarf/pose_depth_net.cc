#include "nerfreg/dbarf/pose_depth_net.h"

#include <cmath>

#include "nerfreg/dbarf/inverse_warp.h"
#include "nerfreg/dbarf/se3.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

namespace nn = torch::nn;
namespace F = torch::nn::functional;

nn::Conv2d Conv(int64_t in, int64_t out, int64_t kh, int64_t kw, int64_t stride = 1, bool bias = true) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, {kh, kw}).stride(stride).padding({kh / 2, kw / 2}).bias(bias));
}

// BatchNorm with running statistics for inference, or (batch_statistics) without: then it
// normalises with the statistics of the images it is given, in training and inference alike.
nn::BatchNorm2d Bn(int64_t channels, bool batch_statistics) {
  return nn::BatchNorm2d(nn::BatchNorm2dOptions(channels).track_running_stats(!batch_statistics));
}

// ResNet BasicBlock: 3x3 (stride) -> BN -> ReLU -> 3x3 -> BN, residual (projected when needed).
class BasicBlockImpl : public nn::Module {
 public:
  BasicBlockImpl(int64_t in, int64_t out, int64_t stride, bool batch_statistics) {
    body_ =
        register_module("body", nn::Sequential(Conv(in, out, 3, 3, stride, false), Bn(out, batch_statistics),
                                               nn::ReLU(), Conv(out, out, 3, 3, 1, false), Bn(out, batch_statistics)));
    if (stride != 1 || in != out) {
      shortcut_ =
          register_module("shortcut", nn::Sequential(Conv(in, out, 1, 1, stride, false), Bn(out, batch_statistics)));
    }
  }
  torch::Tensor forward(const torch::Tensor& x) {
    return torch::relu(body_->forward(x) + (shortcut_ ? shortcut_->forward(x) : x));
  }

 private:
  nn::Sequential body_{nullptr}, shortcut_{nullptr};
};
TORCH_MODULE(BasicBlock);

nn::Sequential Stage(int64_t in, int64_t out, int64_t stride, int64_t blocks, bool batch_statistics) {
  nn::Sequential s;
  for (int64_t b = 0; b < blocks; ++b) {
    s->push_back(BasicBlock(b == 0 ? in : out, out, b == 0 ? stride : 1, batch_statistics));
  }
  return s;
}

// conv3x3 -> ReLU -> conv (3x3, or 1x1 for the mask heads).
nn::Sequential Head(int64_t in, int64_t hidden, int64_t out, int64_t last_kernel = 3) {
  return nn::Sequential(Conv(in, hidden, 3, 3), nn::ReLU(), Conv(hidden, out, last_kernel, last_kernel));
}

// Images in [0, 1] to roughly zero-mean, unit-variance inputs.
torch::Tensor NormaliseImage(const torch::Tensor& x) { return (x - 0.45) / 0.225; }

}  // namespace

PoseDepthNetOptions PoseDepthNetOptions::Paper() { return {}; }

PoseDepthNetOptions PoseDepthNetOptions::Cpu() {
  PoseDepthNetOptions o;
  o.encoder_widths = {16, 32, 64};
  o.blocks_per_stage = 1;
  o.fuse_channels = 32;
  o.feature_channels = 32;
  o.hidden_channels = 32;
  o.context_channels = 8;
  o.motion_channels = 32;
  o.state_channels = 16;
  o.head_channels = 32;
  o.mask_channels = 64;
  o.outer_iterations = 2;
  o.inner_iterations = 2;
  return o;
}

bool PoseDepthNetOptions::Check() const {
  if (encoder_widths.size() != 3) {
    LOG_ERROR("PoseDepthNetOptions: encoder_widths needs 3 entries (layer1..layer3)");
    return false;
  }
  for (int64_t w : encoder_widths) {
    if (w < 1) {
      LOG_ERROR("PoseDepthNetOptions: encoder widths must be >= 1");
      return false;
    }
  }
  if (blocks_per_stage < 1 || fuse_channels < 1 || feature_channels < 1 || hidden_channels < 1 ||
      context_channels < 1 || state_channels < 1 || head_channels < 1 || mask_channels < 1) {
    LOG_ERROR("PoseDepthNetOptions: channel and block counts must be >= 1");
    return false;
  }
  if (motion_channels < 7) {
    LOG_ERROR("PoseDepthNetOptions: motion_channels must exceed the 6 pose channels it appends");
    return false;
  }
  if (outer_iterations < 0 || inner_iterations < 1) {
    LOG_ERROR("PoseDepthNetOptions: need outer_iterations >= 0 and inner_iterations >= 1");
    return false;
  }
  if (!(near > 0.0 && far > near)) {
    LOG_ERROR("PoseDepthNetOptions: need 0 < near < far, got near {} far {}", near, far);
    return false;
  }
  if (!(rotation_scale > 0.0)) {
    LOG_ERROR("PoseDepthNetOptions: rotation_scale must be > 0");
    return false;
  }
  return true;
}

torch::Tensor FeatureCostMaps(const torch::Tensor& target_features, const torch::Tensor& source_features,
                              const torch::Tensor& tgt_inv_depth, const torch::Tensor& src_from_tgt,
                              const torch::Tensor& intrinsics) {
  TORCH_CHECK(target_features.dim() == 4 && target_features.size(0) == 1,
              "FeatureCostMaps: target features must be [1, C, h, w], got ", target_features.sizes());
  TORCH_CHECK(source_features.dim() == 4 && source_features.sizes().slice(1) == target_features.sizes().slice(1),
              "FeatureCostMaps: source features must be [N, C, h, w] like the target, got ", source_features.sizes());
  TORCH_CHECK(tgt_inv_depth.dim() == 4 && tgt_inv_depth.size(0) == 1 &&
                  tgt_inv_depth.size(2) == target_features.size(2) && tgt_inv_depth.size(3) == target_features.size(3),
              "FeatureCostMaps: inverse depth must be [1, 1, h, w] at the feature size, got ", tgt_inv_depth.sizes());
  const InverseWarpResult warp = InverseWarp(source_features, tgt_inv_depth, src_from_tgt, intrinsics);
  return (warp.warped - target_features).pow(2);
}

torch::Tensor ConvexUpsample(const torch::Tensor& x, const torch::Tensor& mask, int64_t factor) {
  TORCH_CHECK(x.dim() == 4 && x.size(1) == 1, "ConvexUpsample: x must be [B, 1, h, w], got ", x.sizes());
  const int64_t b = x.size(0), h = x.size(2), w = x.size(3);
  TORCH_CHECK(mask.dim() == 4 && mask.size(0) == b && mask.size(1) == 9 * factor * factor && mask.size(2) == h &&
                  mask.size(3) == w,
              "ConvexUpsample: mask must be [B, 9 * factor^2, h, w], got ", mask.sizes());
  const torch::Tensor weights = torch::softmax(mask.view({b, 1, 9, factor, factor, h, w}), 2);
  const torch::Tensor patches = F::unfold(x, F::UnfoldFuncOptions({3, 3}).padding(1)).view({b, 1, 9, 1, 1, h, w});
  const torch::Tensor up = (weights * patches).sum(2);  // [B, 1, f, f, h, w]
  return up.permute({0, 1, 4, 2, 5, 3}).reshape({b, 1, factor * h, factor * w});
}

ResNetEncoderImpl::ResNetEncoderImpl(int64_t in_channels, int64_t out_channels, const PoseDepthNetOptions& options) {
  const auto& w = options.encoder_widths;
  const bool batch = options.batch_statistics;
  stem_ = register_module("stem", nn::Sequential(Conv(in_channels, w[0], 7, 7, 2, false), Bn(w[0], batch), nn::ReLU(),
                                                 nn::MaxPool2d(nn::MaxPool2dOptions(3).stride(2).padding(1))));
  layer1_ = register_module("layer1", Stage(w[0], w[0], 1, options.blocks_per_stage, batch));
  layer2_ = register_module("layer2", Stage(w[0], w[1], 2, options.blocks_per_stage, batch));
  layer3_ = register_module("layer3", Stage(w[1], w[2], 2, options.blocks_per_stage, batch));
  up_conv_ = register_module("up_conv", Conv(w[2], options.fuse_channels, 3, 3));
  fuse_conv_ = register_module("fuse_conv", Conv(options.fuse_channels + w[1], options.fuse_channels, 3, 3));
  out_conv_ = register_module("out_conv", Conv(options.fuse_channels, out_channels, 1, 1));
}

torch::Tensor ResNetEncoderImpl::forward(const torch::Tensor& x) {
  const torch::Tensor x2 = layer2_->forward(layer1_->forward(stem_->forward(x)));  // 1/8
  const torch::Tensor x3 = layer3_->forward(x2);                                   // 1/16
  const torch::Tensor up = F::interpolate(x3, F::InterpolateFuncOptions()
                                                  .size(std::vector<int64_t>{x2.size(2), x2.size(3)})
                                                  .mode(torch::kBilinear)
                                                  .align_corners(false));
  const torch::Tensor y = torch::relu(up_conv_->forward(up));
  return out_conv_->forward(torch::relu(fuse_conv_->forward(torch::cat({y, x2}, 1))));
}

SepConvGruImpl::SepConvGruImpl(int64_t hidden_channels, int64_t input_channels) {
  const int64_t in = hidden_channels + input_channels;
  convz1_ = register_module("convz1", Conv(in, hidden_channels, 1, 5));
  convr1_ = register_module("convr1", Conv(in, hidden_channels, 1, 5));
  convq1_ = register_module("convq1", Conv(in, hidden_channels, 1, 5));
  convz2_ = register_module("convz2", Conv(in, hidden_channels, 5, 1));
  convr2_ = register_module("convr2", Conv(in, hidden_channels, 5, 1));
  convq2_ = register_module("convq2", Conv(in, hidden_channels, 5, 1));
}

torch::Tensor SepConvGruImpl::forward(torch::Tensor h, const torch::Tensor& x) {
  const auto step = [&](nn::Conv2d& cz, nn::Conv2d& cr, nn::Conv2d& cq) {
    const torch::Tensor hx = torch::cat({h, x}, 1);
    const torch::Tensor z = torch::sigmoid(cz->forward(hx));
    const torch::Tensor r = torch::sigmoid(cr->forward(hx));
    const torch::Tensor q = torch::tanh(cq->forward(torch::cat({r * h, x}, 1)));
    h = (1 - z) * h + z * q;
  };
  step(convz1_, convr1_, convq1_);
  step(convz2_, convr2_, convq2_);
  return h;
}

MotionEncoderImpl::MotionEncoderImpl(int64_t cost_channels, int64_t state_map_channels,
                                     const PoseDepthNetOptions& options) {
  const int64_t m = options.motion_channels, s = options.state_channels;
  convc1_ = register_module("convc1", Conv(cost_channels, m, 1, 1));
  convc2_ = register_module("convc2", Conv(m, m, 3, 3));
  convs1_ = register_module("convs1", Conv(state_map_channels, m, 7, 7));
  convs2_ = register_module("convs2", Conv(m, s, 3, 3));
  conv_ = register_module("conv", Conv(m + s, m - state_map_channels, 3, 3));
}

torch::Tensor MotionEncoderImpl::forward(const torch::Tensor& cost, const torch::Tensor& state_map) {
  const torch::Tensor c = torch::relu(convc2_->forward(torch::relu(convc1_->forward(cost))));
  const torch::Tensor s = torch::relu(convs2_->forward(torch::relu(convs1_->forward(state_map))));
  return torch::cat({torch::relu(conv_->forward(torch::cat({c, s}, 1))), state_map}, 1);
}

PoseDepthNetImpl::PoseDepthNetImpl(const PoseDepthNetOptions& options) : options_(options) {
  TORCH_CHECK(options_.Check(), "PoseDepthNet: invalid options");
  const auto& o = options_;
  const int64_t f = o.feature_channels, hid = o.hidden_channels, ctx = o.context_channels;
  const int64_t mask_out = 9 * kPoseDepthFeatureStride * kPoseDepthFeatureStride;
  fnet_ = register_module("fnet", ResNetEncoder(3, f, o));
  cnet_depth_ = register_module("cnet_depth", ResNetEncoder(3, hid + ctx, o));
  cnet_pose_ = register_module("cnet_pose", ResNetEncoder(6, hid + ctx, o));
  init_depth_head_ = register_module("init_depth_head", Head(f, o.head_channels, 1));
  init_pose_head_ = register_module("init_pose_head", Head(2 * f, o.head_channels, 6));
  init_mask_head_ = register_module("init_mask_head", Head(f, o.mask_channels, mask_out, 1));
  depth_encoder_ = register_module("depth_encoder", MotionEncoder(f, 1, o));
  pose_encoder_ = register_module("pose_encoder", MotionEncoder(f, 6, o));
  depth_gru_ = register_module("depth_gru", SepConvGru(hid, ctx + o.motion_channels));
  pose_gru_ = register_module("pose_gru", SepConvGru(hid, ctx + o.motion_channels));
  depth_delta_head_ = register_module("depth_delta_head", Head(hid, o.head_channels, 1));
  depth_mask_head_ = register_module("depth_mask_head", Head(hid, o.mask_channels, mask_out, 1));
  pose_delta_head_ = register_module("pose_delta_head", Head(hid, o.head_channels, 6));
  // The pose heads start at zero twists: an untrained network returns its initial poses unchanged
  // (the identity, or the cameras it is given) instead of random motions, so refining a classical
  // initialisation starts from that initialisation's error and training can only improve on it.
  torch::NoGradGuard no_grad;
  for (auto* head : {&init_pose_head_, &pose_delta_head_}) {
    auto last = (*head)->ptr(2)->as<nn::Conv2d>();
    last->weight.zero_();
    if (last->bias.defined()) last->bias.zero_();
  }
}

void PoseDepthNetImpl::ReinitialiseHeads() {
  torch::NoGradGuard no_grad;
  const std::vector<std::shared_ptr<nn::Module>> parts = {
      init_depth_head_.ptr(), init_pose_head_.ptr(), init_mask_head_.ptr(), depth_encoder_.ptr(),
      pose_encoder_.ptr(),    depth_gru_.ptr(),      pose_gru_.ptr(),       depth_delta_head_.ptr(),
      depth_mask_head_.ptr(), pose_delta_head_.ptr()};
  // Only convolutions: these parts have no normalisation layers (the encoders' BatchNorm stays).
  for (const auto& part : parts) {
    for (const auto& module : part->modules(/*include_self=*/true)) {
      if (auto* conv = module->as<nn::Conv2dImpl>()) conv->reset_parameters();
    }
  }
  for (auto* head : {&init_pose_head_, &pose_delta_head_}) {
    auto last = (*head)->ptr(2)->as<nn::Conv2d>();
    last->weight.zero_();
    if (last->bias.defined()) last->bias.zero_();
  }
  // The rotation scale stays the current one: zero rows are zero at any scale.
}

void PoseDepthNetImpl::SetDepthRange(double near, double far) {
  TORCH_CHECK(near > 0.0 && far > near, "PoseDepthNet: need 0 < near < far, got ", near, " ", far);
  options_.near = near;
  options_.far = far;
}

void PoseDepthNetImpl::SetRotationScale(double scale) {
  TORCH_CHECK(scale > 0.0 && std::isfinite(scale), "PoseDepthNet: need a rotation scale > 0, got ", scale);
  const double factor = options_.rotation_scale / scale;
  torch::NoGradGuard no_grad;
  for (auto* head : {&init_pose_head_, &pose_delta_head_}) {
    auto last = (*head)->ptr(2)->as<nn::Conv2d>();
    last->weight.narrow(0, 3, 3).mul_(factor);  // [6, C, k, k]: rows 3-5 are the rotation
    if (last->bias.defined()) last->bias.narrow(0, 3, 3).mul_(factor);
  }
  options_.rotation_scale = scale;
}

torch::Tensor PoseDepthNetImpl::ToInverseDepth(const torch::Tensor& disparity) const {
  const double lo = 1.0 / options_.far, hi = 1.0 / options_.near;
  return lo + (hi - lo) * disparity;
}

torch::Tensor PoseDepthNetImpl::TwistFromHead(const torch::Tensor& head_output) const {
  const torch::Tensor xi = head_output.mean({2, 3});  // [N, 6] = (rho, omega)
  return torch::cat({xi.narrow(1, 0, 3), options_.rotation_scale * xi.narrow(1, 3, 3)}, 1);
}

PoseDepthPrediction PoseDepthNetImpl::forward(const torch::Tensor& target, const torch::Tensor& sources,
                                              const torch::Tensor& intrinsics,
                                              const torch::Tensor& initial_src_from_tgt) {
  TORCH_CHECK(target.dim() == 4 && target.size(0) == 1 && target.size(1) == 3,
              "PoseDepthNet: target must be [1, 3, H, W], got ", target.sizes());
  TORCH_CHECK(sources.dim() == 4 && sources.size(0) >= 1 && sources.sizes().slice(1) == target.sizes().slice(1),
              "PoseDepthNet: sources must be [N, 3, H, W] like the target, got ", sources.sizes());
  TORCH_CHECK(target.size(2) >= 16 && target.size(3) >= 16, "PoseDepthNet: images must be at least 16 x 16");
  TORCH_CHECK(intrinsics.dim() == 2 && intrinsics.size(0) == 3 && intrinsics.size(1) == 3,
              "PoseDepthNet: intrinsics must be [3, 3], got ", intrinsics.sizes());
  const int64_t n = sources.size(0), height = target.size(2), width = target.size(3);
  const int64_t factor = kPoseDepthFeatureStride;
  const torch::Tensor tgt = NormaliseImage(target), src = NormaliseImage(sources);

  const torch::Tensor fmaps = fnet_->forward(torch::cat({tgt, src}, 0));
  const torch::Tensor f_tgt = fmaps.narrow(0, 0, 1), f_src = fmaps.narrow(0, 1, n);
  const int64_t h = f_tgt.size(2), w = f_tgt.size(3);
  const torch::Tensor k_low = ScaleIntrinsics(intrinsics.to(f_tgt.scalar_type()), 1.0 / factor);
  const auto upsample = [&](const torch::Tensor& disparity, const torch::Tensor& mask) {
    torch::Tensor up = ConvexUpsample(disparity, mask, factor);
    if (up.size(2) != height || up.size(3) != width) {
      up = F::interpolate(up, F::InterpolateFuncOptions()
                                  .size(std::vector<int64_t>{height, width})
                                  .mode(torch::kBilinear)
                                  .align_corners(false));
    }
    return ToInverseDepth(up);
  };

  // Initial predictions (the pose head's twist corrects the given initial poses when there are any).
  const torch::Tensor init_twist =
      TwistFromHead(init_pose_head_->forward(torch::cat({f_tgt.expand({n, -1, h, w}), f_src}, 1)));
  torch::Tensor src_from_tgt;
  if (initial_src_from_tgt.defined()) {
    TORCH_CHECK(initial_src_from_tgt.sizes() == torch::IntArrayRef({n, 4, 4}),
                "PoseDepthNet: initial poses must be [N, 4, 4], got ", initial_src_from_tgt.sizes());
    src_from_tgt = Se3Update(init_twist, initial_src_from_tgt.detach().to(init_twist.scalar_type()));
  } else {
    src_from_tgt = Se3Exp(init_twist);
  }
  torch::Tensor disparity = torch::sigmoid(init_depth_head_->forward(f_tgt));  // [1, 1, h, w]
  PoseDepthPrediction out;
  out.target_features = f_tgt;
  out.inv_depths.push_back(upsample(disparity, 0.25 * init_mask_head_->forward(f_tgt)));
  out.src_from_tgt.push_back(src_from_tgt);
  if (options_.outer_iterations == 0) return out;

  // Context networks: GRU hidden states (tanh) and context (ReLU).
  const int64_t hid = options_.hidden_channels, ctx = options_.context_channels;
  const torch::Tensor cd = cnet_depth_->forward(tgt);
  torch::Tensor hidden_d = torch::tanh(cd.narrow(1, 0, hid));
  const torch::Tensor context_d = torch::relu(cd.narrow(1, hid, ctx));
  const torch::Tensor cp = cnet_pose_->forward(torch::cat({tgt.expand({n, -1, -1, -1}), src}, 1));
  torch::Tensor hidden_p = torch::tanh(cp.narrow(1, 0, hid));
  const torch::Tensor context_p = torch::relu(cp.narrow(1, hid, ctx));

  for (int64_t outer = 0; outer < options_.outer_iterations; ++outer) {
    disparity = disparity.detach();
    src_from_tgt = src_from_tgt.detach();
    torch::Tensor mask;
    // Depth: the cost averaged over the views, poses fixed.
    for (int64_t step = 0; step < options_.inner_iterations; ++step) {
      const torch::Tensor cost =
          FeatureCostMaps(f_tgt, f_src, ToInverseDepth(disparity), src_from_tgt, k_low).mean(0, true);
      const torch::Tensor motion = depth_encoder_->forward(cost, disparity);
      hidden_d = depth_gru_->forward(hidden_d, torch::cat({context_d, motion}, 1));
      // Kept in [0, 1] in the forward pass, but with the gradient of the unclamped update (straight
      // through): a plain clamp has zero gradient outside the range, so once a photometric loss had
      // pushed every pixel to the far bound (which it does while the poses are poor: at infinite
      // depth only the rotation moves pixels) no loss could bring the depth back.
      const torch::Tensor raw = disparity + torch::tanh(depth_delta_head_->forward(hidden_d));  // [1, 1, h, w]
      disparity = raw + (raw.clamp(0.0, 1.0) - raw).detach();
      mask = 0.25 * depth_mask_head_->forward(hidden_d);
    }
    // Poses: one cost map per view, with the depth just updated (detached).
    const torch::Tensor inv_depth = ToInverseDepth(disparity).detach();
    for (int64_t step = 0; step < options_.inner_iterations; ++step) {
      const torch::Tensor cost = FeatureCostMaps(f_tgt, f_src, inv_depth, src_from_tgt, k_low);
      const torch::Tensor pose_map = Se3Log(src_from_tgt).view({n, 6, 1, 1}).expand({n, 6, h, w});
      const torch::Tensor motion = pose_encoder_->forward(cost, pose_map);
      hidden_p = pose_gru_->forward(hidden_p, torch::cat({context_p, motion}, 1));
      src_from_tgt = Se3Update(TwistFromHead(pose_delta_head_->forward(hidden_p)), src_from_tgt);
    }
    out.inv_depths.push_back(upsample(disparity, mask));
    out.src_from_tgt.push_back(src_from_tgt);
  }
  return out;
}

}  // namespace nerfreg
