#include "nerfreg/reg/dreg_model.h"

#include <cmath>
#include <stdexcept>

#include "nerfreg/geometry/alignment.h"
#include "nerfreg/reg/positional_encoding.h"
#include "nerfreg/reg/weighted_procrustes.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/torch_archive.h"

namespace nerfreg {
namespace {

namespace nn = torch::nn;
using torch::indexing::Slice;

const char* kWeightsFormatTag = "nerfreg-dreg-weights";

struct Keypoints {
  torch::Tensor xyz;       // [M, 3]
  torch::Tensor features;  // [M, C]
  torch::Tensor surface;   // [M]
};

void CheckGrid(const RegGrid& g, const char* name) {
  TORCH_CHECK(g.rgba.defined() && g.rgba.dim() == 4 && g.rgba.size(0) == 4, "DregNet: ", name,
              ".rgba must be [4, D, D, D]");
  const int64_t d = g.rgba.size(1);
  TORCH_CHECK(g.rgba.size(2) == d && g.rgba.size(3) == d, "DregNet: ", name, ".rgba must be cubic");
  TORCH_CHECK(g.xyz.sizes() == torch::IntArrayRef({d, d, d, 3}), "DregNet: ", name, ".xyz must be [D, D, D, 3]");
  TORCH_CHECK(g.surface.sizes() == torch::IntArrayRef({d, d, d}), "DregNet: ", name, ".surface must be [D, D, D]");
  TORCH_CHECK(g.mask.sizes() == torch::IntArrayRef({d, d, d}) && g.mask.scalar_type() == torch::kBool,
              "DregNet: ", name, ".mask must be [D, D, D] bool");
  TORCH_CHECK(g.mask.any().item<bool>(), "DregNet: ", name, ".mask is empty");
}

Keypoints GatherKeypoints(Backbone& backbone, const RegGrid& g, const torch::Device& device) {
  const torch::Tensor mask = g.mask.to(device);
  Keypoints k;
  k.features = backbone->ForwardAtMask(g.rgba.to(device, torch::kFloat).unsqueeze(0), mask);
  k.xyz = g.xyz.to(device, torch::kFloat).index({mask});
  k.surface = g.surface.to(device, torch::kFloat).index({mask});
  return k;
}

std::vector<int64_t> Ints(const JsonField& j) {
  std::vector<int64_t> v;
  for (size_t i = 0; i < j.ArraySize(); ++i) v.push_back(j[i].Int());
  return v;
}

// First differing leaf between two JSON values ("" when equal), as a dotted path.
std::string FirstDifference(const Json& a, const Json& b, const std::string& path) {
  if (a.is_object() && b.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it) {
      const std::string p = path.empty() ? it.key() : path + "." + it.key();
      if (!b.contains(it.key())) return p;
      const std::string d = FirstDifference(it.value(), b.at(it.key()), p);
      if (!d.empty()) return d;
    }
    for (auto it = b.begin(); it != b.end(); ++it) {
      if (!a.contains(it.key())) return path.empty() ? it.key() : path + "." + it.key();
    }
    return "";
  }
  return a == b ? "" : (path.empty() ? "options" : path);
}

const Json* At(const Json& j, const std::string& dotted) {
  const Json* cur = &j;
  size_t start = 0;
  while (cur && start <= dotted.size()) {
    const size_t end = dotted.find('.', start);
    const std::string key = dotted.substr(start, end == std::string::npos ? std::string::npos : end - start);
    cur = (cur->is_object() && cur->contains(key)) ? &cur->at(key) : nullptr;
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return cur;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Options.

DregModelOptions DregModelOptions::Paper() { return {}; }

DregModelOptions DregModelOptions::Cpu() {
  DregModelOptions o;
  o.backbone.stem_channels = 16;
  o.backbone.stage_widths = {16, 32, 64};
  o.backbone.stage_blocks = {1, 1, 1};
  o.backbone.fpn_channels = 64;
  o.d_model = 64;
  o.heads = 4;
  o.layers = 4;
  o.ffn = 256;
  o.downsample.max_total_points = 1000;
  o.name = "cpu";
  return o;
}

void DregModelOptions::Check() const {
  if (!backbone.Check()) throw std::invalid_argument("backbone: invalid backbone options");
  if (d_model < 6) throw std::invalid_argument("d_model: expected >= 6");
  if (heads < 1 || d_model % heads != 0) throw std::invalid_argument("heads: expected >= 1 and dividing d_model");
  if (layers < 1) throw std::invalid_argument("layers: expected >= 1");
  if (ffn < 1) throw std::invalid_argument("ffn: expected >= 1");
  if (!downsample.Check()) throw std::invalid_argument("downsample: invalid downsampling options");
}

Json DregModelOptions::ToJson() const {
  return {{"name", name},
          {"backbone",
           {{"in_channels", backbone.in_channels},
            {"stem_channels", backbone.stem_channels},
            {"stage_widths", backbone.stage_widths},
            {"stage_blocks", backbone.stage_blocks},
            {"fpn_channels", backbone.fpn_channels}}},
          {"d_model", d_model},
          {"heads", heads},
          {"layers", layers},
          {"ffn", ffn},
          {"downsample", {{"voxel_sizes", downsample.voxel_sizes}, {"max_total_points", downsample.max_total_points}}},
          {"estimate_scale", estimate_scale}};
}

DregModelOptions DregModelOptions::FromJson(const Json& json, const std::string& file) {
  const JsonField j(json, file);
  DregModelOptions o;
  o.name = j.StringOr("name", "");
  const JsonField b = j["backbone"];
  o.backbone.in_channels = b["in_channels"].Int();
  o.backbone.stem_channels = b["stem_channels"].Int();
  o.backbone.stage_widths = Ints(b["stage_widths"]);
  o.backbone.stage_blocks = Ints(b["stage_blocks"]);
  o.backbone.fpn_channels = b["fpn_channels"].Int();
  o.d_model = j["d_model"].Int();
  o.heads = j["heads"].Int();
  o.layers = j["layers"].Int();
  o.ffn = j["ffn"].Int();
  o.downsample.voxel_sizes = j["downsample"]["voxel_sizes"].Doubles();
  o.downsample.max_total_points = j["downsample"]["max_total_points"].Int();
  o.estimate_scale = j["estimate_scale"].Bool();
  try {
    o.Check();
  } catch (const std::invalid_argument& e) {
    j.Fail(std::string("valid DReg model options (") + e.what() + ")");
  }
  return o;
}

// ---------------------------------------------------------------------------------------------
// Modules.

CorrespondenceDecoderImpl::CorrespondenceDecoderImpl(int64_t d_model) : d_model_(d_model) {
  q_proj = register_module("q_proj", nn::Linear(d_model, d_model));
  k_proj = register_module("k_proj", nn::Linear(d_model, d_model));
  conf_head = register_module("conf_head", nn::Linear(d_model, 1));
}

torch::Tensor CorrespondenceDecoderImpl::Correspond(const torch::Tensor& f, const torch::Tensor& pe,
                                                    const torch::Tensor& f_other, const torch::Tensor& pe_other,
                                                    const torch::Tensor& xyz_other) {
  TORCH_CHECK(f.dim() == 2 && f.size(1) == d_model_ && pe.sizes() == f.sizes(), "Correspond: f, pe must be [M, d]");
  TORCH_CHECK(f_other.dim() == 2 && f_other.size(1) == d_model_ && pe_other.sizes() == f_other.sizes(),
              "Correspond: f_other, pe_other must be [N, d]");
  TORCH_CHECK(xyz_other.dim() == 2 && xyz_other.size(0) == f_other.size(0) && xyz_other.size(1) == 3,
              "Correspond: xyz_other must be [N, 3]");
  const torch::Tensor q = q_proj->forward(f + pe) / std::sqrt(static_cast<double>(d_model_));
  const torch::Tensor k = k_proj->forward(f_other + pe_other);
  const torch::Tensor attn = torch::softmax(torch::matmul(q, k.t()), /*dim=*/1);  // [M, N]
  return torch::matmul(attn, xyz_other);
}

torch::Tensor CorrespondenceDecoderImpl::ConfidenceLogits(const torch::Tensor& f) {
  TORCH_CHECK(f.dim() == 2 && f.size(1) == d_model_, "ConfidenceLogits: f must be [M, d]");
  return conf_head->forward(f).squeeze(1);
}

DregNetImpl::DregNetImpl(const DregModelOptions& options) : options_(options) {
  options_.Check();
  backbone = register_module("backbone", Backbone(options_.backbone));
  feat_proj = register_module("feat_proj", nn::Linear(options_.backbone.fpn_channels, options_.d_model));
  CrossTransformerOptions t;
  t.d_model = options_.d_model;
  t.heads = options_.heads;
  t.layers = options_.layers;
  t.ffn = options_.ffn;
  transformer = register_module("transformer", CrossTransformer(t));
  decoder = register_module("decoder", CorrespondenceDecoder(options_.d_model));
  feature_w = register_parameter("feature_w", torch::randn({options_.d_model, options_.d_model}) * 0.1);
}

DregOutput DregNetImpl::forward(const RegGrid& src, const RegGrid& tgt) {
  CheckGrid(src, "src");
  CheckGrid(tgt, "tgt");
  const torch::Device device = feature_w.device();
  const Keypoints s = GatherKeypoints(backbone, src, device);
  const Keypoints t = GatherKeypoints(backbone, tgt, device);
  // S rides along as the last feature column so that it is averaged with the same cells.
  const DownsampledPair ds =
      VoxelDownsamplePair(s.xyz, torch::cat({s.features, s.surface.unsqueeze(1)}, 1), t.xyz,
                          torch::cat({t.features, t.surface.unsqueeze(1)}, 1), options_.downsample);
  const int64_t c = options_.backbone.fpn_channels;
  DregOutput out;
  out.voxel_size = ds.voxel_size;
  out.src_xyz = ds.src.xyz.detach();
  out.tgt_xyz = ds.tgt.xyz.detach();
  out.src_surface = ds.src.features.index({Slice(), c}).detach();
  out.tgt_surface = ds.tgt.features.index({Slice(), c}).detach();
  out.feature_w = feature_w;

  PositionalEncodingOptions pe_options;
  pe_options.d_model = options_.d_model;
  const torch::Tensor src_pe = SinePositionalEncoding(out.src_xyz, pe_options);
  const torch::Tensor tgt_pe = SinePositionalEncoding(out.tgt_xyz, pe_options);
  const CrossTransformerOutput enc =
      transformer->forward(feat_proj->forward(ds.src.features.index({Slice(), Slice(0, c)})),
                           feat_proj->forward(ds.tgt.features.index({Slice(), Slice(0, c)})), src_pe, tgt_pe);

  std::vector<torch::Tensor> x_src, x_tgt, weights;
  for (int64_t l = 0; l < options_.layers; ++l) {
    const torch::Tensor& fs = enc.src[l];
    const torch::Tensor& ft = enc.tgt[l];
    out.src_features.push_back(fs);
    out.tgt_features.push_back(ft);
    out.src_corr.push_back(decoder->Correspond(fs, src_pe, ft, tgt_pe, out.tgt_xyz));
    out.tgt_corr.push_back(decoder->Correspond(ft, tgt_pe, fs, src_pe, out.src_xyz));
    out.src_conf_logits.push_back(decoder->ConfidenceLogits(fs));
    out.tgt_conf_logits.push_back(decoder->ConfidenceLogits(ft));
    out.src_conf.push_back(torch::sigmoid(out.src_conf_logits.back()));
    out.tgt_conf.push_back(torch::sigmoid(out.tgt_conf_logits.back()));
    // Both directions stacked: source keypoints -> their matches, target keypoints' matches ->
    // target keypoints.
    x_src.push_back(torch::cat({out.src_xyz, out.tgt_corr.back()}, 0));
    x_tgt.push_back(torch::cat({out.src_corr.back(), out.tgt_xyz}, 0));
    weights.push_back(torch::cat({out.src_conf.back(), out.tgt_conf.back()}, 0));
  }
  WeightedProcrustesOptions wp;
  wp.estimate_scale = options_.estimate_scale;
  const WeightedProcrustesResult pose =
      WeightedProcrustes(torch::stack(x_src), torch::stack(x_tgt), torch::stack(weights), wp);
  for (int64_t l = 0; l < options_.layers; ++l) {
    out.rotation.push_back(pose.rotation[l]);
    out.translation.push_back(pose.translation[l]);
    out.scale.push_back(pose.scale[l]);
    out.pose_valid.push_back(pose.valid[l]);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Registration.

RegistrationAgreement ScoreRegistration(const torch::Tensor& x_src, const torch::Tensor& x_tgt,
                                        const torch::Tensor& conf, const torch::Tensor& rotation,
                                        const torch::Tensor& translation, double scale, double inlier_radius) {
  TORCH_CHECK(x_src.dim() == 2 && x_src.size(1) == 3 && x_tgt.sizes() == x_src.sizes(),
              "ScoreRegistration: x_src, x_tgt must be [N, 3]");
  TORCH_CHECK(conf.dim() == 1 && conf.size(0) == x_src.size(0), "ScoreRegistration: conf must be [N]");
  TORCH_CHECK(rotation.sizes() == torch::IntArrayRef({3, 3}) && translation.sizes() == torch::IntArrayRef({3}),
              "ScoreRegistration: rotation [3, 3], translation [3]");
  TORCH_CHECK(inlier_radius > 0.0, "ScoreRegistration: inlier_radius must be > 0");
  RegistrationAgreement a;
  if (x_src.size(0) == 0) return a;
  const torch::Tensor c = conf.to(torch::kDouble).clamp(0.0, 1.0);
  const torch::Tensor moved =
      scale * torch::matmul(x_src.to(torch::kDouble), rotation.to(torch::kDouble).t()) + translation.to(torch::kDouble);
  const torch::Tensor inlier = ((moved - x_tgt.to(torch::kDouble)).norm(2, 1) < inlier_radius).to(torch::kDouble);
  const double total = c.sum().item<double>();
  a.mean_confidence = c.mean().item<double>();
  a.inlier_fraction = total > 0.0 ? (c * inlier).sum().item<double>() / total : 0.0;
  a.confidence = a.inlier_fraction * a.mean_confidence;
  return a;
}

void DregSolveOptions::Check() const {
  if (solver != "procrustes" && solver != "ransac") ThrowInputError("--dreg-solver", "", "procrustes or ransac");
  if (!(inlier_radius > 0)) ThrowInputError("--inlier-radius", "", "> 0");
  if (ransac_iterations < 1) ThrowInputError("--ransac-iterations", "", ">= 1");
  if (passes < 1 || passes > 10) ThrowInputError("--dreg-passes", "", "1 to 10");
}

namespace {

// One network pass: the pose of the last layer's correspondences.
DregRegistration RegisterOnce(DregNet& net, const RegGrid& src, const RegGrid& tgt, const DregSolveOptions& options) {
  DregRegistration r;
  if (src.mask.sum().item<int64_t>() < 3 || tgt.mask.sum().item<int64_t>() < 3) return r;
  // Eval mode for the duration of the call, restored even if the forward pass throws.
  struct ModeGuard {
    DregNet& net;
    bool was_training;
    ~ModeGuard() { net->train(was_training); }
  } guard{net, net->is_training()};
  net->eval();
  torch::NoGradGuard no_grad;
  const DregOutput out = net->forward(src, tgt);
  const int64_t l = out.num_layers() - 1;
  // Both directions of the last layer: source keypoints with their matches in the target, and
  // the target keypoints' matches in the source with the target keypoints.
  const torch::Tensor x_src = torch::cat({out.src_xyz, out.tgt_corr[l]}).to(torch::kDouble).cpu();
  const torch::Tensor x_tgt = torch::cat({out.src_corr[l], out.tgt_xyz}).to(torch::kDouble).cpu();
  const torch::Tensor conf = torch::cat({out.src_conf[l], out.tgt_conf[l]}).to(torch::kDouble).cpu();
  torch::Tensor rot = out.rotation[l].to(torch::kDouble).cpu();
  torch::Tensor trans = out.translation[l].to(torch::kDouble).cpu();
  r.scale = out.scale[l].item<double>();
  r.valid = out.pose_valid[l].item<bool>();
  if (options.solver == "ransac") {
    RobustAlignmentOptions ro;
    ro.estimate_scale = net->options().estimate_scale;
    ro.inlier_radius = options.inlier_radius;
    ro.iterations = options.ransac_iterations;
    ro.seed = options.seed;
    const torch::Tensor c = conf.contiguous();
    const Eigen::VectorXd w = Eigen::Map<const Eigen::VectorXd>(c.data_ptr<double>(), c.size(0));
    const RobustAlignmentResult robust = EstimateSim3dRansac(PointsToEigen(x_src), PointsToEigen(x_tgt), w, ro);
    // Without a consistent hypothesis the network's own pose (and its validity) stands.
    if (robust.valid) {
      const Eigen::Matrix3d R = robust.tgt_from_src.rotation.toRotationMatrix();
      rot = torch::from_blob(const_cast<double*>(Eigen::Matrix<double, 3, 3, Eigen::RowMajor>(R).data()), {3, 3},
                             torch::kDouble)
                .clone();
      trans =
          torch::from_blob(const_cast<double*>(robust.tgt_from_src.translation.data()), {3}, torch::kDouble).clone();
      r.scale = robust.tgt_from_src.scale;
      r.valid = true;
    }
  }
  r.src_points = static_cast<int>(out.src_xyz.size(0));
  r.tgt_points = static_cast<int>(out.tgt_xyz.size(0));
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.target_from_source(i, j) = r.scale * rot[i][j].item<double>();
    r.target_from_source(i, 3) = trans[i].item<double>();
  }
  const RegistrationAgreement a = ScoreRegistration(x_src, x_tgt, conf, rot, trans, r.scale, options.inlier_radius);
  if (r.valid) {
    r.confidence = a.confidence;
    r.inlier_fraction = a.inlier_fraction;
    r.mean_confidence = a.mean_confidence;
  }
  return r;
}

}  // namespace

DregRegistration Register(DregNet& net, const RegGrid& src, const RegGrid& tgt, const DregSolveOptions& options) {
  options.Check();
  DregRegistration r = RegisterOnce(net, src, tgt, options);
  const int passes = net->options().estimate_scale ? 1 : options.passes;
  for (int pass = 1; pass < passes && r.valid; ++pass) {
    // The source seen from the target frame as estimated so far: the network now corrects a
    // small residual pose (target_from_moved), and target_from_source = that * the estimate.
    const Eigen::Matrix4d& T = r.target_from_source;
    const RegGrid moved = TransformRegGrid(src, T.topLeftCorner<3, 3>(), T.topRightCorner<3, 1>());
    DregRegistration next = RegisterOnce(net, moved, tgt, options);
    if (!next.valid) break;
    next.target_from_source = next.target_from_source * T;
    r = next;
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Weights files.

void SaveDregWeights(DregNet& net, const DregModelOptions& options, const std::string& path) {
  const Json meta = {{"format", kWeightsFormatTag}, {"version", kDregWeightsVersion}, {"options", options.ToJson()}};
  torch::serialize::OutputArchive archive;
  archive.write("meta", StringTensor(meta.dump()));
  torch::serialize::OutputArchive model_archive;
  net->save(model_archive);
  archive.write("model", model_archive);
  SaveArchiveAtomic(archive, path);
}

namespace {
// The dominant weights the options imply (backbone.cc, transformer.cc): convolutions of the stem,
// the bottlenecks (3x3x3 and 1x1x1), FPN laterals and smoothing, the projection to d_model, and
// per transformer layer self and cross attention (4 d^2 each) and the FFN.
double DregParameterLowerBound(const DregModelOptions& o) {
  const BackboneOptions& b = o.backbone;
  const double fpn = b.fpn_channels, d = o.d_model;
  double n = 125.0 * b.in_channels * b.stem_channels + 27.0 * b.stem_channels * fpn + fpn * d;
  for (size_t s = 0; s < b.stage_widths.size() && s < b.stage_blocks.size(); ++s) {
    const double w = b.stage_widths[s];
    n += b.stage_blocks[s] * 31.0 * w * w + 4.0 * w * fpn + 27.0 * fpn * fpn;
  }
  return n + o.layers * (8.0 * d * d + 2.0 * d * o.ffn);
}
}  // namespace

DregNet LoadDregWeights(const std::string& path, DregModelOptions* options) {
  torch::serialize::InputArchive archive;
  const Json meta = LoadArchiveMeta(path, "DReg-NeRF weights file", kWeightsFormatTag, kDregWeightsVersion, &archive);
  if (!meta.contains("options")) ThrowInputError(path, "options", "the network options (written by reg train)");
  const DregModelOptions stored = DregModelOptions::FromJson(meta["options"], path + " (options)");
  CheckArchiveCanHold(path, "options", DregParameterLowerBound(stored));
  DregNet net(stored);
  // Module::load replaces tensors whatever their shape, so the shapes the stored options imply
  // are recorded first and compared afterwards.
  std::vector<std::pair<std::string, std::vector<int64_t>>> expected;
  for (const auto& p : net->named_parameters()) expected.emplace_back(p.key(), p.value().sizes().vec());
  for (const auto& b : net->named_buffers()) expected.emplace_back(b.key(), b.value().sizes().vec());
  try {
    torch::serialize::InputArchive model_archive;
    archive.read("model", model_archive);
    net->load(model_archive);
  } catch (const std::exception& e) {
    ThrowInputError(path, "model", "the parameters of the stored options (tensors missing or unreadable)");
  }
  std::map<std::string, std::vector<int64_t>> loaded;
  for (const auto& p : net->named_parameters()) loaded[p.key()] = p.value().sizes().vec();
  for (const auto& b : net->named_buffers()) loaded[b.key()] = b.value().sizes().vec();
  for (const auto& [name, sizes] : expected) {
    if (loaded[name] != sizes) {
      ThrowInputError(path, "model." + name, "a tensor of the shape its stored options imply");
    }
  }
  if (options) *options = stored;
  return net;
}

DregNet AverageDregWeights(const std::vector<std::string>& paths, DregModelOptions* options) {
  if (paths.empty()) throw InputError("reg average: expected at least one weights file");
  DregModelOptions first;
  DregNet mean = LoadDregWeights(paths[0], &first);
  torch::NoGradGuard no_grad;
  auto mean_params = mean->named_parameters();
  auto mean_buffers = mean->named_buffers();
  for (size_t i = 1; i < paths.size(); ++i) {
    DregModelOptions stored;
    DregNet net = LoadDregWeights(paths[i], &stored);
    CheckDregOptionsMatch(stored, first, paths[i]);
    for (const auto& p : net->named_parameters()) mean_params[p.key()].add_(p.value());
    for (const auto& b : net->named_buffers()) {
      if (b.value().is_floating_point()) mean_buffers[b.key()].add_(b.value());
    }
  }
  const double n = static_cast<double>(paths.size());
  for (auto& p : mean_params) p.value().div_(n);
  for (auto& b : mean_buffers) {
    if (b.value().is_floating_point()) b.value().div_(n);
  }
  if (options) *options = first;
  return mean;
}

void CheckDregOptionsMatch(const DregModelOptions& stored, const DregModelOptions& wanted, const std::string& path) {
  // Only the fields that shape the tensors; the label, point budget and scale solve may differ.
  Json a = wanted.ToJson(), b = stored.ToJson();
  for (const char* key : {"name", "downsample", "estimate_scale"}) {
    a.erase(key);
    b.erase(key);
  }
  const std::string field = FirstDifference(a, b, "");
  if (field.empty()) return;
  const Json* w = At(a, field);
  const Json* s = At(b, field);
  ThrowInputError(path, "options." + field,
                  (w ? w->dump() : std::string("(absent)")) + " as configured, but these weights have " +
                      (s ? s->dump() : std::string("(absent)")) + " (weights for another model configuration)");
}

}  // namespace nerfreg
