// The DReg-NeRF registration network (spec dreg-nerf.md 4; the design of REGTR with a 3D CNN
// front end), its options, the registration result with a confidence that is low when the blocks
// do not overlap, and its weights files.
//
// Data flow for one pair (M = masked voxels, K = keypoints after downsampling, d = d_model,
// L = transformer layers; every tensor float32 on the module's device):
//   grid.rgba [4,D,D,D] --Backbone (shared)--> [C_fpn,D,D,D] --gather at grid.mask--> [M, C_fpn]
//   grid.xyz at mask [M,3], grid.surface at mask [M]       (each block in its own frame)
//   VoxelDownsamplePair (same cell size for both; S rides along as an extra feature column)
//        -> xyz [K,3], features [K,C_fpn], surface label [K]
//   feat_proj Linear(C_fpn -> d) -> [K,d];  PE = SinePositionalEncoding(xyz) [K,d]
//   CrossTransformer -> per layer l: f_src^l [Ks,d], f_tgt^l [Kt,d]
//   decoder (shared by all layers, single head):
//     src_corr^l = softmax_j( Wq(f_src+PE_src) . Wk(f_tgt+PE_tgt) / sqrt(d) ) @ tgt_xyz  [Ks,3] (target frame)
//     tgt_corr^l likewise [Kt,3] (source frame); confidence = sigmoid(Linear(d->1)(f)) [Ks], [Kt]
//   pose^l = WeightedProcrustes( [src_xyz ; tgt_corr^l] -> [src_corr^l ; tgt_xyz],
//                                weights [conf_src^l ; conf_tgt^l] )   (tgt_from_src)
// The last layer's pose is the network's answer; every layer's is supervised (REGTR).
#pragma once

#include <torch/torch.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "nerfreg/reg/backbone.h"
#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/reg/transformer.h"
#include "nerfreg/reg/voxel_downsample.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct DregModelOptions {
  // The 3D ResNet-FPN front end (its fpn_channels are projected to d_model).
  BackboneOptions backbone;
  // Transformer width d (also the positional encoding and decoder width).
  int64_t d_model = 256;
  // Attention heads of the transformer (d_model divisible by heads).
  int64_t heads = 8;
  // Transformer layers; each is decoded into correspondences and a pose.
  int64_t layers = 6;
  // FFN hidden width.
  int64_t ffn = 1024;
  // Keypoint downsampling cascade and the point budget for source + target together.
  VoxelDownsampleOptions downsample;
  // Solve Sim(3) (a scale) instead of SE(3); the paper solves SE(3).
  bool estimate_scale = false;
  // A label written next to results ("paper", "cpu", ...); not part of the architecture.
  std::string name = "paper";

  // Paper: ResNet-50 FPN 256, d 256, 8 heads, 6 layers, FFN 1024, 3000 points.
  static DregModelOptions Paper();
  // Trains on 2 CPU cores: widths {16,32,64}, blocks {1,1,1}, FPN/d 64, 4 heads, 4 layers, FFN 256,
  // 1000 points; grids of D = 64 (32 works too).
  static DregModelOptions Cpu();
  Json ToJson() const;
  // Throws InputError naming `file` and the field when the JSON is malformed or invalid.
  static DregModelOptions FromJson(const Json& json, const std::string& file);
  // Throws std::invalid_argument naming the field when a value is out of range.
  void Check() const;
};

// Everything one forward pass produces. K_s / K_t: keypoints after downsampling; L: layers.
struct DregOutput {
  torch::Tensor src_xyz;                       // [Ks, 3] keypoints in the source block's frame.
  torch::Tensor tgt_xyz;                       // [Kt, 3] keypoints in the target block's frame.
  torch::Tensor src_surface;                   // [Ks] surface-field label S in [0, 1] (cell mean), no grad.
  torch::Tensor tgt_surface;                   // [Kt]
  std::vector<torch::Tensor> src_features;     // L x [Ks, d], after the final LayerNorm.
  std::vector<torch::Tensor> tgt_features;     // L x [Kt, d]
  std::vector<torch::Tensor> src_corr;         // L x [Ks, 3] source keypoints' matches, TARGET frame.
  std::vector<torch::Tensor> tgt_corr;         // L x [Kt, 3] target keypoints' matches, SOURCE frame.
  std::vector<torch::Tensor> src_conf_logits;  // L x [Ks] confidence logits.
  std::vector<torch::Tensor> tgt_conf_logits;  // L x [Kt]
  std::vector<torch::Tensor> src_conf;         // L x [Ks] sigmoid(logits) in (0, 1).
  std::vector<torch::Tensor> tgt_conf;         // L x [Kt]
  std::vector<torch::Tensor> rotation;         // L x [3, 3] tgt_from_src, det +1.
  std::vector<torch::Tensor> translation;      // L x [3] tgt_from_src: x_tgt = s R x_src + t.
  std::vector<torch::Tensor> scale;            // L x [] (1 unless estimate_scale).
  std::vector<torch::Tensor> pose_valid;       // L x [] bool (false: degenerate weights).
  torch::Tensor feature_w;                     // [d, d] the model's InfoNCE bilinear parameter (for DregLoss).
  double voxel_size = 0.0;                     // downsampling cell used (0: none needed).

  int64_t num_layers() const { return static_cast<int64_t>(rotation.size()); }
};

// The single-head correspondence decoder and confidence head, shared by all layers.
class CorrespondenceDecoderImpl : public torch::nn::Module {
 public:
  explicit CorrespondenceDecoderImpl(int64_t d_model);
  // f [M, d], pe [M, d], f_other [N, d], pe_other [N, d], xyz_other [N, 3] float32.
  // Returns [M, 3]: the attention-weighted mean of xyz_other (in the other cloud's frame).
  torch::Tensor Correspond(const torch::Tensor& f, const torch::Tensor& pe, const torch::Tensor& f_other,
                           const torch::Tensor& pe_other, const torch::Tensor& xyz_other);
  // f [M, d] -> [M] confidence logits.
  torch::Tensor ConfidenceLogits(const torch::Tensor& f);

  torch::nn::Linear q_proj{nullptr}, k_proj{nullptr}, conf_head{nullptr};

 private:
  int64_t d_model_;
};
TORCH_MODULE(CorrespondenceDecoder);

class DregNetImpl : public torch::nn::Module {
 public:
  explicit DregNetImpl(const DregModelOptions& options);
  // src, tgt: grids of any (each divisible by 2^(stages+1)) resolution, each mask with >= 1 voxel.
  // Uses src.rgba/xyz/surface/mask and aabb only.
  DregOutput forward(const RegGrid& src, const RegGrid& tgt);
  const DregModelOptions& options() const { return options_; }

  Backbone backbone{nullptr};
  torch::nn::Linear feat_proj{nullptr};
  CrossTransformer transformer{nullptr};
  CorrespondenceDecoder decoder{nullptr};
  // [d, d] InfoNCE bilinear matrix (REGTR's W), symmetrised in the loss. A parameter of the
  // model so that the optimizer trains it (the original left it out: spec 9.4).
  torch::Tensor feature_w;

 private:
  DregModelOptions options_;
};
TORCH_MODULE(DregNet);

// How well the stacked correspondences agree with a solved pose, the basis of the registration
// confidence. For correspondences x_src[i] -> x_tgt[i] with confidences c_i and the pose
// (s, R, t):
//   inlier_fraction = sum_i c_i [ |s R x_src[i] + t - x_tgt[i]| < inlier_radius ] / sum_i c_i
//   mean_confidence = mean_i c_i
//   confidence      = inlier_fraction * mean_confidence            (in [0, 1])
// Low when the network is unsure (low c), when matches scatter (non-overlapping blocks: the
// soft attention averages far-apart points, so matches collapse toward the other cloud's centre
// and no rigid motion of a spread cloud reaches them), or when the solution is a compromise.
struct RegistrationAgreement {
  double inlier_fraction = 0.0;
  double mean_confidence = 0.0;
  double confidence = 0.0;
};
// x_src, x_tgt [N, 3], conf [N] in [0, 1]; rotation [3, 3], translation [3]; any float dtype.
RegistrationAgreement ScoreRegistration(const torch::Tensor& x_src, const torch::Tensor& x_tgt,
                                        const torch::Tensor& conf, const torch::Tensor& rotation,
                                        const torch::Tensor& translation, double scale, double inlier_radius);

struct DregRegistration {
  // x_tgt = target_from_source * [x_src; 1]; the top-left block is scale * R.
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double scale = 1.0;
  // ScoreRegistration on the last layer (see RegistrationAgreement); 0 when not solvable.
  double confidence = 0.0;
  double inlier_fraction = 0.0;
  double mean_confidence = 0.0;
  // Keypoints after downsampling.
  int src_points = 0;
  int tgt_points = 0;
  // False when a mask has < 3 voxels or the weights were degenerate (pose = identity).
  bool valid = false;
};

// How a registration turns the network's correspondences into one pose.
struct DregSolveOptions {
  // "procrustes": the paper's weighted Kabsch over all of the last layer's correspondences (the
  // pose the network outputs). "ransac": RANSAC over the same confidence-weighted
  // correspondences, both directions (geometry/alignment.h), then weighted Kabsch on its inliers.
  // RANSAC pays only when a consistent subset of matches is right; the shipped CPU weights' soft
  // matches are spread, and once refined its poses lost held-out pairs that the paper's solve kept
  // (docs/notes/2026-11-24-experiments-not-kept.md), so the paper's solve is the default.
  std::string solver = "procrustes";
  // Scene units: the confidence's agreement radius and RANSAC's inlier radius (e.g. 2 cells of
  // the coarsest cloud, ~0.1).
  double inlier_radius = 0.1;
  int ransac_iterations = 2000;
  unsigned seed = 0;
  // Network passes: each pass after the first runs the network again on the source grid moved by
  // the pose so far (TransformRegGrid) and composes the correction. The paper runs one. A second
  // pass sharpens the network's own pose a little but lost pairs once ICP refined it
  // (docs/notes/2026-11-24-experiments-not-kept.md). SE(3) weights only: with estimate_scale the
  // extra passes are skipped.
  int passes = 1;
  void Check() const;  // throws InputError naming the option
};

// Runs the network in eval mode without gradients (restoring the previous mode) and returns the
// pose solved from the last layer's correspondences (composed over `passes`); the confidence,
// inlier fraction and keypoint counts are the last pass's.
DregRegistration Register(DregNet& net, const RegGrid& src, const RegGrid& tgt, const DregSolveOptions& options);

// Weights files: a torch archive holding a format tag, a version and the options JSON next to
// the parameters and buffers; written atomically.
constexpr int kDregWeightsVersion = 1;
void SaveDregWeights(DregNet& net, const DregModelOptions& options, const std::string& path);
// Throws InputError naming the file when it is missing, truncated, not DReg weights, of another
// version, or holds tensors that do not fit its stored options. *options receives the stored ones.
DregNet LoadDregWeights(const std::string& path, DregModelOptions* options);
// The element-wise mean of several weights files of one architecture (a "model soup",
// Wortsman et al. 2022): runs fine-tuned from the same start differ here about as much as
// recipes do, and their mean is one network that needs no pick among them. Parameters and
// floating buffers are averaged; integer buffers are the first file's. Throws InputError naming
// the file (and the field) that cannot be read or whose architecture differs from the first's.
// *options receives the first file's options.
DregNet AverageDregWeights(const std::vector<std::string>& paths, DregModelOptions* options);
// For --weights next to an explicit config: throws InputError("PATH: FIELD: expected ...")
// naming the first architecture field (backbone, d_model, heads, layers, ffn) where the stored
// options differ from `wanted`; the name label, the downsampling budget and estimate_scale may
// differ (they change no tensor).
void CheckDregOptionsMatch(const DregModelOptions& stored, const DregModelOptions& wanted, const std::string& path);

}  // namespace nerfreg
