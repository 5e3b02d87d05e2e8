// DBARF's pose/depth network (spec dbarf.md 3): from one target image and N source images it
// predicts the target's inverse depth and the relative pose src_from_tgt of every source, by
// recurrent refinement on feature-metric cost maps at 1/8 resolution.
//
//   fnet (target and sources, shared) -> 1/8 feature maps, F channels
//   initial heads: DepthHead(target fmap) -> normalised disparity d in (0, 1);
//                  PoseHead(concat(target fmap, source_i fmap)) -> twist -> Exp -> src_from_tgt
//   cnet_depth(target), cnet_pose(concat(target, source_i)) -> GRU hidden (tanh) and context (ReLU)
//   outer iterations (depth and poses detached at the start of each; hidden states are not):
//     depth: inner steps of  cost = mean_i FeatureCostMaps(...)  ->  motion encoder  -> SepConvGRU
//            -> d <- clamp(d + tanh(head), 0, 1)
//     poses: inner steps of  cost_i = FeatureCostMaps(view i)  ->  motion encoder (pose as a
//            6-channel map)  ->  SepConvGRU  ->  PoseHead  ->  src_from_tgt_i <- Exp(delta) src_from_tgt_i
//     the depth is upsampled x8 by convex combination (mask from the depth GRU), then resized.
// Inverse depth = 1/far + (1/near - 1/far) d, so it always lies in [1/far, 1/near].
//
// Departures from the original, on purpose: poses are updated on SE(3) with twists (rho, omega)
// (translation first; the original added Euler angles), the pose steps see the depth just updated
// (detached) rather than the one from before the depth steps, grid sampling uses the project's
// pixel-centre convention (align_corners = false, border padding), and the 1/8 intrinsics scale
// fx, fy, cx and cy on a copy (spec 9.1).
#pragma once

#include <torch/torch.h>

#include <vector>

namespace nerfreg {

struct PoseDepthNetOptions {
  // Widths of the ResNet18 stages layer1..layer3 (the stem outputs the layer1 width). Paper 64,
  // 128, 256.
  std::vector<int64_t> encoder_widths = {64, 128, 256};
  // BasicBlocks per stage (ResNet18: 2).
  int64_t blocks_per_stage = 2;
  // Width of the stride-8 fusion (layer3 up-conv, fuse conv). Paper 128.
  int64_t fuse_channels = 128;
  // Channels F of the matching features (fnet output, cost-map channels). Paper 128.
  int64_t feature_channels = 128;
  // GRU hidden channels (tanh part of the context nets). Paper 128.
  int64_t hidden_channels = 128;
  // Context channels (ReLU part of the context nets). Paper 32.
  int64_t context_channels = 32;
  // Motion-encoder output = GRU input minus context; also its cost-branch width. Paper 128.
  int64_t motion_channels = 128;
  // Width of the motion encoder's depth/pose branch output. Paper 64.
  int64_t state_channels = 64;
  // Hidden width of the depth and pose heads. Paper 128.
  int64_t head_channels = 128;
  // Hidden width of the convex-upsampling mask heads. Paper 256.
  int64_t mask_channels = 256;
  // Outer iterations (each adds one prediction) and GRU steps per outer iteration. Paper 3 x 4.
  int64_t outer_iterations = 3;
  int64_t inner_iterations = 4;
  // Depth range in scene units; the inverse depth lies in [1/far, 1/near]. Original 0.1 / 100.
  double near = 0.1;
  double far = 100.0;
  // Scale on the rotation half of every predicted twist (keeps early rotations small). Paper 0.01.
  double rotation_scale = 0.01;
  // The encoders' BatchNorm normalises with the statistics of the images it is given (a target and
  // its sources, one scene) in inference too, as in training, instead of the running statistics
  // (the original's), which average over every scene trained on and so fit no one scene; the
  // training step never used them (docs/notes/2026-11-25-pose-network-batch-norm.md). Weights
  // files written with running statistics load either way (the statistics are then unused).
  bool batch_statistics = true;

  // The original sizes, and a small CPU configuration (channels / 4, 2 outer x 2 inner).
  static PoseDepthNetOptions Paper();
  static PoseDepthNetOptions Cpu();
  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

// The stride of the feature maps (fixed by the encoder: conv s2, maxpool s2, layer2 s2).
constexpr int64_t kPoseDepthFeatureStride = 8;

// Feature-metric cost maps: target pixels (of the h x w feature map) are back-projected with the
// target inverse depth, moved into source i by src_from_tgt[i], projected and the source features
// sampled bilinearly; cost = per-channel squared difference.
//  target_features:  [1, C, h, w] float.
//  source_features:  [N, C, h, w] float.
//  tgt_inv_depth:    [1, 1, h, w] float, > 0.
//  src_from_tgt:     [N, 4, 4] float.
//  intrinsics:       [3, 3] float, for the h x w maps (use ScaleIntrinsics(K, 1.0 / 8)).
// Returns [N, C, h, w]. Points leaving the source read its border features (no masking), as the
// original reads zeros; the network learns from the cost whatever the validity.
torch::Tensor FeatureCostMaps(const torch::Tensor& target_features, const torch::Tensor& source_features,
                              const torch::Tensor& tgt_inv_depth, const torch::Tensor& src_from_tgt,
                              const torch::Tensor& intrinsics);

// Convex upsampling (RAFT): every output pixel of the factor x factor block of a low-res pixel is a
// softmax-weighted combination of the 3 x 3 low-res neighbourhood.
// x: [B, 1, h, w]; mask: [B, 9 * factor^2, h, w] logits. Returns [B, 1, factor * h, factor * w].
torch::Tensor ConvexUpsample(const torch::Tensor& x, const torch::Tensor& mask, int64_t factor);

// ResNet18-style encoder to stride 8 with the layer3 -> 1/8 upsample-and-fuse (spec 3).
// Input [B, in_channels, H, W] -> [B, out_channels, ceil-ish(H / 8), ceil-ish(W / 8)].
class ResNetEncoderImpl : public torch::nn::Module {
 public:
  ResNetEncoderImpl(int64_t in_channels, int64_t out_channels, const PoseDepthNetOptions& options);
  torch::Tensor forward(const torch::Tensor& x);

 private:
  torch::nn::Sequential stem_{nullptr}, layer1_{nullptr}, layer2_{nullptr}, layer3_{nullptr};
  torch::nn::Conv2d up_conv_{nullptr}, fuse_conv_{nullptr}, out_conv_{nullptr};
};
TORCH_MODULE(ResNetEncoder);

// Separable ConvGRU: a 1x5 GRU step then a 5x1 step. h: [B, hidden, h, w], x: [B, input, h, w].
class SepConvGruImpl : public torch::nn::Module {
 public:
  SepConvGruImpl(int64_t hidden_channels, int64_t input_channels);
  torch::Tensor forward(torch::Tensor h, const torch::Tensor& x);

 private:
  torch::nn::Conv2d convz1_{nullptr}, convr1_{nullptr}, convq1_{nullptr};
  torch::nn::Conv2d convz2_{nullptr}, convr2_{nullptr}, convq2_{nullptr};
};
TORCH_MODULE(SepConvGru);

// Motion encoder: cost -> 1x1 -> 3x3; state map (depth 1 ch / pose 6 ch) -> 7x7 -> 3x3; concat ->
// 3x3 -> (motion - state) channels; the raw state map is appended. Output [B, motion, h, w].
class MotionEncoderImpl : public torch::nn::Module {
 public:
  MotionEncoderImpl(int64_t cost_channels, int64_t state_map_channels, const PoseDepthNetOptions& options);
  torch::Tensor forward(const torch::Tensor& cost, const torch::Tensor& state_map);

 private:
  torch::nn::Conv2d convc1_{nullptr}, convc2_{nullptr}, convs1_{nullptr}, convs2_{nullptr}, conv_{nullptr};
};
TORCH_MODULE(MotionEncoder);

struct PoseDepthPrediction {
  // K = outer_iterations + 1 predictions: the initial heads, then one after each outer iteration.
  // inv_depths[k]: [1, 1, H, W] float32 at the input image size, in [1/far, 1/near].
  std::vector<torch::Tensor> inv_depths;
  // src_from_tgt[k]: [N, 4, 4] float32, x_in_src_i = R x_in_tgt + t.
  std::vector<torch::Tensor> src_from_tgt;
  // [1, feature_channels, h, w]: the target's matching features (the original returns them too).
  torch::Tensor target_features;
};

class PoseDepthNetImpl : public torch::nn::Module {
 public:
  explicit PoseDepthNetImpl(const PoseDepthNetOptions& options);
  // target: [1, 3, H, W] float32 in [0, 1]; sources: [N, 3, H, W] float32 in [0, 1];
  // intrinsics: [3, 3] float32 in pixels of the H x W images. H, W >= 16.
  // initial_src_from_tgt: undefined, or [N, 4, 4] relative poses to start from (e.g. the classical
  // cameras of sfm/global_sfm.h): the initial pose head then predicts a correction of them rather
  // than the poses themselves, and the recurrent updates refine from there (no gradient flows
  // into the given poses).
  PoseDepthPrediction forward(const torch::Tensor& target, const torch::Tensor& sources,
                              const torch::Tensor& intrinsics, const torch::Tensor& initial_src_from_tgt = {});
  const PoseDepthNetOptions& options() const { return options_; }
  // The depth range of the scene at hand (0 < near < far; scene units): the network predicts a
  // normalised disparity in (0, 1) and this maps it to inverse depth, so one set of weights serves
  // scenes of different extents (DBARF passes each scene's bounds the same way).
  void SetDepthRange(double near, double far);
  // Changes the rotation scale of the pose heads to `scale` (> 0) and divides the rotation rows of
  // their last layers by the change, so the network computes the same function: only how fast
  // training moves rotations changes (Adam steps are about the same size in every parameter, so a
  // smaller scale turns rotations more slowly).
  void SetRotationScale(double scale);
  // Draws every parameter except the three encoders' (fnet, cnet_depth, cnet_pose) afresh: the
  // initial heads, the motion encoders, the GRUs and the update heads, the pose heads' last layers
  // at zero, so the network returns the identity (or the given initial poses) again. The original
  // starts its encoders from ImageNet's ResNet18 and these parts fresh; with no pretrained weights
  // downloaded here, a trained network's encoders stand in (`dbarf pretrain --fresh-pose-heads`).
  // Draws from torch's generator: seed it for a repeatable run.
  void ReinitialiseHeads();

 private:
  torch::Tensor ToInverseDepth(const torch::Tensor& disparity) const;
  torch::Tensor TwistFromHead(const torch::Tensor& head_output) const;

  PoseDepthNetOptions options_;
  ResNetEncoder fnet_{nullptr}, cnet_depth_{nullptr}, cnet_pose_{nullptr};
  torch::nn::Sequential init_depth_head_{nullptr}, init_pose_head_{nullptr}, init_mask_head_{nullptr};
  MotionEncoder depth_encoder_{nullptr}, pose_encoder_{nullptr};
  SepConvGru depth_gru_{nullptr}, pose_gru_{nullptr};
  torch::nn::Sequential depth_delta_head_{nullptr}, depth_mask_head_{nullptr}, pose_delta_head_{nullptr};
};
TORCH_MODULE(PoseDepthNet);

}  // namespace nerfreg
