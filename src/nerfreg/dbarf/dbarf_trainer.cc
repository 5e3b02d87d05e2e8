#include "nerfreg/dbarf/dbarf_trainer.h"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <ATen/CPUGeneratorImpl.h>

#include "nerfreg/dbarf/ibr_render.h"
#include "nerfreg/dist/dist.h"
#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/sfm_loss.h"
#include "nerfreg/util/torch_device.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/torch_archive.h"
#include "nerfreg/util/training_log.h"

namespace nerfreg {
namespace {

const char* kStateFormat = "nerfreg-dbarf-train-state";
constexpr int kStateVersion = 1;

void SetLearningRates(torch::optim::Adam* optimizer, const std::vector<double>& base, double factor) {
  auto& groups = optimizer->param_groups();
  for (size_t g = 0; g < groups.size() && g < base.size(); ++g) {
    static_cast<torch::optim::AdamOptions&>(groups[g].options()).lr(base[g] * factor);
  }
}

// Rotation angle (degrees) of every R_a^T R_b: a, b [N, 4, 4] -> [N].
torch::Tensor RotationAngleDeg(const torch::Tensor& a, const torch::Tensor& b) {
  const torch::Tensor ra = a.slice(1, 0, 3).slice(2, 0, 3), rb = b.slice(1, 0, 3).slice(2, 0, 3);
  const torch::Tensor trace = torch::matmul(ra.transpose(1, 2), rb).diagonal(0, 1, 2).sum(1);
  return torch::acos(((trace - 1) / 2).clamp(-1, 1)) * (180.0 / M_PI);
}

}  // namespace

void DbarfScene::Check() const {
  const std::string what = "scene " + name;
  if (!images.defined() || images.dim() != 4 || images.size(1) != 3 || images.size(0) < 2) {
    ThrowInputError(name, "images", "at least 2 RGB images of one size");
  }
  const int64_t v = images.size(0);
  if (!intrinsics.defined() || intrinsics.sizes() != torch::IntArrayRef({v, 3, 3})) {
    ThrowInputError(name, "intrinsics", "one 3x3 matrix per image");
  }
  if (cam_from_world.defined() && cam_from_world.sizes() != torch::IntArrayRef({v, 4, 4})) {
    ThrowInputError(name, "cam_from_world", "one 4x4 camera per image");
  }
  if (static_cast<int64_t>(neighbours.size()) != v || static_cast<int64_t>(usable.size()) != v ||
      static_cast<int64_t>(image_names.size()) != v) {
    ThrowInputError(name, "view_graph", "neighbours, names and usable flags for every image");
  }
  for (const auto& n : neighbours)
    for (int j : n)
      if (j < 0 || j >= v) ThrowInputError(name, "view_graph", "neighbour indices within the images");
  if (!(near > 0 && far > near && std::isfinite(far))) {
    ThrowInputError(name, "near/far",
                    "a depth range 0 < near < far, got " + std::to_string(near) + ", " + std::to_string(far));
  }
}

const char* DbarfStageName(DbarfStage stage) {
  switch (stage) {
    case DbarfStage::kPose:
      return "pose";
    case DbarfStage::kNerf:
      return "nerf";
    case DbarfStage::kJoint:
      return "joint";
  }
  return "?";
}

torch::Tensor BoxBlur(const torch::Tensor& images, int radius, int passes) {
  TORCH_CHECK(images.dim() == 4 && radius >= 0 && passes >= 0, "BoxBlur: expected [N, C, H, W], radius, passes >= 0");
  torch::Tensor out = images;
  namespace F = torch::nn::functional;
  for (int p = 0; p < passes && radius > 0; ++p) {
    out =
        F::avg_pool2d(out, F::AvgPool2dFuncOptions(2 * radius + 1).stride(1).padding(radius).count_include_pad(false));
  }
  return out;
}

DbarfStage DbarfStageOfStep(int64_t step, int64_t stage_steps) {
  const int64_t k = step / std::max<int64_t>(stage_steps, 1);
  if (k > 0 && k % 3 == 0) return DbarfStage::kJoint;
  return k % 2 == 0 ? DbarfStage::kPose : DbarfStage::kNerf;
}

DbarfTrainOptions DbarfTrainOptions::Pretrain() { return {}; }

DbarfTrainOptions DbarfTrainOptions::Finetune() {
  DbarfTrainOptions o;
  o.num_sources = 10;
  o.source_jitter_min = -2;
  o.source_jitter_max = 1;
  o.lr_feature = 5e-4;
  o.lr_mlp = 2e-4;
  o.lr_pose = 1e-5;
  o.lr_decay_steps = 20000;
  return o;
}

void DbarfTrainOptions::Check() const {
  if (stage_steps < 1) throw InputError("--stage-steps: expected >= 1, got " + std::to_string(stage_steps));
  if (num_sources < 1) throw InputError("--sources: expected >= 1, got " + std::to_string(num_sources));
  if (source_jitter_min > source_jitter_max) throw InputError("source jitter: expected min <= max");
  if (rays_per_step < 1) throw InputError("--rays: expected >= 1, got " + std::to_string(rays_per_step));
  if (!(lr_feature > 0 && lr_mlp > 0 && lr_pose > 0)) throw InputError("learning rates: expected > 0");
  if (lr_decay_steps < 1 || !(lr_gamma > 0 && lr_gamma <= 1))
    throw InputError("lr decay: expected steps >= 1, 0 < gamma <= 1");
  if (!(joint_decay >= 0)) throw InputError("joint_decay: expected >= 0");
  if (schedule != "dbarf" && schedule != "nerf") {
    throw InputError("--schedule: expected \"dbarf\" or \"nerf\", got \"" + schedule + "\"");
  }
  if (pose_init != "network" && pose_init != "cameras") {
    throw InputError("--pose-init: expected \"network\" or \"cameras\", got \"" + pose_init + "\"");
  }
  if (nerf_poses != "network" && nerf_poses != "cameras") {
    throw InputError("--nerf-poses: expected \"network\" or \"cameras\", got \"" + nerf_poses + "\"");
  }
  if (!(init_noise_deg >= 0 && init_noise_deg <= 30)) throw InputError("--init-noise-deg: expected 0 to 30");
  if (!(init_noise_translation >= 0 && init_noise_translation <= 1)) {
    throw InputError("--init-noise-translation: expected 0 to 1 (a fraction of each baseline)");
  }
  if (refine_cameras && nerf_poses != "cameras") {
    throw InputError("--refine-cameras: the RGB loss reaches the cameras only with --nerf-poses cameras");
  }
  if (!(lr_cameras > 0)) throw InputError("--lr-cameras: expected > 0");
  if ((init_noise_deg > 0 || init_noise_translation > 0) && pose_init != "cameras") {
    throw InputError(
        "--init-noise-deg / --init-noise-translation: perturb camera initialisations, so need --pose-init cameras");
  }
  if (!sfm.Check()) throw InputError("SfM loss options: expected valid weights (see the log)");
  if (samples_per_step < 0 || samples_per_step > 4096) {
    throw InputError("--batch: expected targets per step in [1, 4096] (0: one per process), got " +
                     std::to_string(samples_per_step));
  }
  if (!(supervise_rotation_weight >= 0 && std::isfinite(supervise_rotation_weight))) {
    throw InputError("--supervise-rotation-weight: expected >= 0, got " + std::to_string(supervise_rotation_weight));
  }
  if (!(blur_probability >= 0 && blur_probability <= 1) || blur_max_radius < 1) {
    throw InputError("--augment-blur: expected a probability in [0, 1] (and a blur radius >= 1)");
  }
  if (!(supervise_depth >= 0 && std::isfinite(supervise_depth))) {
    throw InputError("--supervise-depth: expected a weight >= 0, got " + std::to_string(supervise_depth));
  }
  if (!(supervise_poses >= 0 && std::isfinite(supervise_poses))) {
    throw InputError("--supervise-poses: expected a weight >= 0, got " + std::to_string(supervise_poses));
  }
}

DbarfTrainer::DbarfTrainer(DbarfModel* model, std::vector<DbarfScene> scenes, const DbarfTrainOptions& options,
                           DistGroup* group)
    : model_(model), scenes_(std::move(scenes)), options_(options), rng_(options.seed) {
  options_.Check();
  if (group == nullptr) single_ = std::make_unique<DistGroup>();
  group_ = group != nullptr ? group : single_.get();
  const int world = group_->world_size();
  samples_per_step_ = options_.samples_per_step > 0 ? options_.samples_per_step : world;
  if (samples_per_step_ < world) {
    ThrowInputError("--batch", "", "at least one target per process (>= " + std::to_string(world) + ")");
  }
  if (options_.refine_cameras && world > 1) {
    ThrowInputError("--refine-cameras", "", "one process (a scene's cameras are refined by one process)");
  }
  if (scenes_.empty()) throw InputError("dbarf training: no scenes");
  for (size_t s = 0; s < scenes_.size(); ++s) {
    scenes_[s].Check();
    if ((options_.nerf_poses == "cameras" || options_.pose_init == "cameras") && !scenes_[s].cam_from_world.defined()) {
      ThrowInputError(scenes_[s].name, "cameras", "estimated cameras (--nerf-poses cameras)");
    }
    if ((options_.supervise_poses > 0 || options_.supervise_depth > 0) &&
        (!scenes_[s].supervision_cam_from_world.defined() ||
         scenes_[s].supervision_cam_from_world.sizes() != torch::IntArrayRef({scenes_[s].NumViews(), 4, 4}))) {
      ThrowInputError(scenes_[s].name, "ground truth", "ground-truth cameras for every image (--supervise-poses)");
    }
    for (int v = 0; v < scenes_[s].NumViews(); ++v)
      if (scenes_[s].usable[v] && !SourcesOf(scenes_[s], v, 1).empty()) targets_.push_back({static_cast<int>(s), v});
  }
  if (targets_.empty()) throw InputError("dbarf training: no usable view has a usable view-graph neighbour");
  using G = torch::optim::OptimizerParamGroup;
  std::vector<G> nerf_groups;
  nerf_groups.emplace_back(model_->nerf.FeatureParameters(),
                           std::make_unique<torch::optim::AdamOptions>(options_.lr_feature));
  nerf_groups.emplace_back(model_->nerf.MlpParameters(), std::make_unique<torch::optim::AdamOptions>(options_.lr_mlp));
  nerf_optimizer_ = std::make_unique<torch::optim::Adam>(nerf_groups, torch::optim::AdamOptions(options_.lr_mlp));
  pose_optimizer_ =
      std::make_unique<torch::optim::Adam>(model_->PoseParameters(), torch::optim::AdamOptions(options_.lr_pose));
  if (options_.refine_cameras) {
    for (const DbarfScene& scene : scenes_) {
      const int64_t v = scene.NumViews();
      const auto f = torch::TensorOptions().dtype(torch::kFloat).device(scene.images.device());
      camera_twists_.push_back(torch::zeros({v, 6}, f).requires_grad_(true));
      torch::Tensor mask = torch::ones({v, 1}, f);
      for (int64_t i = 0; i < v; ++i) {
        if (scene.usable[i]) {
          mask[i] = 0.0;
          break;
        }
      }
      camera_masks_.push_back(mask);
    }
    camera_optimizer_ =
        std::make_unique<torch::optim::Adam>(camera_twists_, torch::optim::AdamOptions(options_.lr_cameras));
  }
  parameters_ = model_->NerfParameters();
  for (const torch::Tensor& p : model_->PoseParameters()) parameters_.push_back(p);
  // Every rank starts from rank 0's weights (and BatchNorm statistics), whatever it loaded.
  std::vector<torch::Tensor> state = parameters_;
  for (const torch::Tensor& b : model_->pose_net->buffers()) state.push_back(b);
  for (const torch::Tensor& b : model_->nerf.feature_net->buffers()) state.push_back(b);
  for (const torch::Tensor& b : model_->nerf.ibrnet->buffers()) state.push_back(b);
  BroadcastParameters(*group_, state);
}

DbarfTrainer::~DbarfTrainer() = default;

torch::Tensor DbarfTrainer::Cameras(int s) const {
  const DbarfScene& scene = scenes_.at(s);
  if (!options_.refine_cameras) return scene.cam_from_world;
  return Se3Update(camera_twists_[s] * camera_masks_[s], scene.cam_from_world);
}

std::vector<int> DbarfTrainer::SourcesOf(const DbarfScene& scene, int target, int k) {
  std::vector<int> out;
  for (int j : scene.neighbours[target]) {
    if (static_cast<int>(out.size()) >= k) break;
    if (j != target && scene.usable[j]) out.push_back(j);
  }
  return out;
}

torch::Tensor SupervisedPoseLoss(const std::vector<torch::Tensor>& src_from_tgts, const torch::Tensor& truth,
                                 double rotation_weight, double prediction_decay) {
  TORCH_CHECK(!src_from_tgts.empty(), "SupervisedPoseLoss: no predictions");
  TORCH_CHECK(truth.dim() == 3 && truth.size(1) == 4 && truth.size(2) == 4, "SupervisedPoseLoss: truth [N, 4, 4], got ",
              truth.sizes());
  const torch::Tensor r_true = truth.slice(1, 0, 3).slice(2, 0, 3);  // [N, 3, 3]
  const torch::Tensor t_true = truth.slice(1, 0, 3).select(2, 3);    // [N, 3]
  // A pose whose source is the target itself has no baseline: its translation error is measured
  // against a tenth of the step's longest baseline instead.
  const torch::Tensor norms = t_true.norm(2, 1);  // [N]
  const torch::Tensor baseline = norms.clamp_min((0.1 * norms.max()).clamp_min(1e-6).item<double>());
  const int64_t k_count = static_cast<int64_t>(src_from_tgts.size());
  torch::Tensor total = torch::zeros({}, truth.options());
  for (int64_t k = 0; k < k_count; ++k) {
    const torch::Tensor& p = src_from_tgts[k];
    TORCH_CHECK(p.sizes() == truth.sizes(), "SupervisedPoseLoss: prediction ", p.sizes(), " vs truth ", truth.sizes());
    // The square root's gradient is unbounded at 0: the epsilon keeps an exact prediction finite.
    const torch::Tensor rot = ((p.slice(1, 0, 3).slice(2, 0, 3) - r_true).pow(2).sum({1, 2}) + 1e-12).sqrt();  // [N]
    const torch::Tensor trans = ((p.slice(1, 0, 3).select(2, 3) - t_true).pow(2).sum(1) + 1e-12).sqrt() / baseline;
    const double w = std::pow(prediction_decay, static_cast<double>(k_count - 1 - k));
    total = total + w * (rotation_weight * rot + trans).mean();
  }
  return total;
}

torch::Tensor GroundTruthInEstimatedScale(const torch::Tensor& true_cam_from_world,
                                          const torch::Tensor& estimated_cam_from_world, const std::vector<bool>& use,
                                          const std::string& source) {
  TORCH_CHECK(true_cam_from_world.dim() == 3 && true_cam_from_world.sizes() == estimated_cam_from_world.sizes() &&
                  true_cam_from_world.size(1) == 4 && true_cam_from_world.size(2) == 4 &&
                  static_cast<int64_t>(use.size()) == true_cam_from_world.size(0),
              "GroundTruthInEstimatedScale: cameras [V, 4, 4] and one flag per view");
  std::vector<int64_t> views;
  for (size_t v = 0; v < use.size(); ++v)
    if (use[v]) views.push_back(static_cast<int64_t>(v));
  if (views.size() < 2) ThrowInputError(source, "ground truth", "at least 2 estimated cameras to fix the scale");
  const auto centres = [&](const torch::Tensor& c) {  // -R^T t of the used views: [U, 3]
    const torch::Tensor u = c.index_select(0, torch::tensor(views, torch::kLong).to(c.device())).to(torch::kDouble);
    return -torch::matmul(u.slice(1, 0, 3).slice(2, 0, 3).transpose(1, 2), u.slice(1, 0, 3).slice(2, 3, 4)).squeeze(2);
  };
  const auto spread = [](const torch::Tensor& c) {
    return (c - c.mean(0, true)).pow(2).sum(1).mean().sqrt().item<double>();
  };
  const double true_spread = spread(centres(true_cam_from_world));
  if (!(true_spread > 1e-12)) ThrowInputError(source, "ground truth", "cameras at distinct centres");
  const double scale = spread(centres(estimated_cam_from_world)) / true_spread;
  torch::Tensor out = true_cam_from_world.to(torch::kFloat).clone();
  out.slice(1, 0, 3).select(2, 3).mul_(scale);
  return out;
}

DbarfScene DbarfSceneTo(const DbarfScene& scene, const torch::Device& device) {
  DbarfScene s = scene;
  for (torch::Tensor* t : {&s.images, &s.intrinsics, &s.cam_from_world, &s.supervision_cam_from_world})
    if (t->defined()) *t = t->to(device);
  return s;
}

torch::Tensor RelativeCameras(const torch::Tensor& cam_from_world, int target, const std::vector<int>& sources) {
  const torch::Tensor idx =
      torch::tensor(std::vector<int64_t>(sources.begin(), sources.end()), torch::kLong).to(cam_from_world.device());
  const torch::Tensor world_from_tgt = Se3Inverse(cam_from_world[target]);
  return torch::matmul(cam_from_world.index_select(0, idx), world_from_tgt);
}

torch::Tensor PerturbRelativePoses(const torch::Tensor& src_from_tgt, double deg, double translation,
                                   c10::optional<at::Generator> generator) {
  TORCH_CHECK(src_from_tgt.dim() == 3 && src_from_tgt.size(1) == 4 && src_from_tgt.size(2) == 4,
              "PerturbRelativePoses: expected [N, 4, 4], got ", src_from_tgt.sizes());
  const int64_t n = src_from_tgt.size(0);
  // Drawn on the CPU (the generators are CPU ones, so a run draws alike on every device).
  const auto options = src_from_tgt.options().device(torch::kCPU);
  const torch::Tensor baseline = src_from_tgt.slice(1, 0, 3).select(2, 3).norm(2, 1, true);  // [N, 1]
  const torch::Tensor rho = torch::randn({n, 3}, generator, options).to(src_from_tgt.device()) * translation * baseline;
  const torch::Tensor omega = torch::randn({n, 3}, generator, options).to(src_from_tgt.device()) * (deg * M_PI / 180.0);
  return Se3Update(torch::cat({rho, omega}, 1), src_from_tgt);
}

DbarfStepResult DbarfTrainer::Step() {
  const DbarfStage stage =
      options_.schedule == "nerf" ? DbarfStage::kNerf : DbarfStageOfStep(step_, options_.stage_steps);
  // Every random draw of the step derives from rng_, whose state SaveState keeps: one seed per
  // target, drawn by every rank alike, each rank training on targets rank, rank + world, ...
  std::vector<uint64_t> seeds(samples_per_step_);
  for (uint64_t& seed : seeds) seed = rng_();
  model_->Train(true);
  nerf_optimizer_->zero_grad();
  pose_optimizer_->zero_grad();
  if (camera_optimizer_) camera_optimizer_->zero_grad();
  const int world = group_->world_size(), rank = group_->rank();
  DbarfStepResult result;
  result.stage = stage;
  std::vector<std::pair<int, int>> touched;  // (scene, view) of the cameras the step's renders used
  int mine = 0;
  // [1] float64: how many targets rendered a valid ray, over every rank.
  torch::Tensor stats = torch::zeros({1}, torch::kFloat64);
  for (int b = rank; b < samples_per_step_; b += world) {
    bool rgb_valid = false;
    const DbarfStepResult r = TrainOnSample(seeds[b], stage, 1.0 / samples_per_step_, &rgb_valid, &touched);
    stats[0] += rgb_valid ? 1.0 : 0.0;
    // This process's targets: the first one's identity, the mean of their figures.
    if (mine == 0)
      result = r;
    else {
      const double w = 1.0 / (mine + 1);
      for (auto [sum, x] : {std::pair<double*, double>{&result.sfm_loss, r.sfm_loss},
                            {&result.rgb_loss, r.rgb_loss},
                            {&result.pose_loss, r.pose_loss},
                            {&result.disparity, r.disparity},
                            {&result.rotation_err_deg, r.rotation_err_deg},
                            {&result.direction_err_deg, r.direction_err_deg},
                            {&result.translation_ratio, r.translation_ratio},
                            {&result.psnr, r.psnr}}) {
        *sum += w * (x - *sum);
      }
    }
    ++mine;
  }
  // Summed over the ranks; each target's loss was already divided by the step's targets, so the
  // sum is their mean, as one process training on all of them has it.
  AllReduceGradients(*group_, parameters_, &stats);
  const bool pose_grad = stage != DbarfStage::kNerf;
  const bool nerf_on = stage != DbarfStage::kPose;
  const bool rgb_valid = stats[0].item<double>() > 0;
  const double decay = std::pow(options_.lr_gamma, static_cast<double>(step_ / options_.lr_decay_steps));
  if (nerf_on && rgb_valid) {
    SetLearningRates(nerf_optimizer_.get(), {options_.lr_feature, options_.lr_mlp}, decay);
    nerf_optimizer_->step();
  }
  if (pose_grad) {
    SetLearningRates(pose_optimizer_.get(), {options_.lr_pose}, decay);
    pose_optimizer_->step();
  }
  if (camera_optimizer_ && stage == DbarfStage::kNerf && rgb_valid) {
    // Adam moves a parameter by its momentum also on steps that gave it no gradient: a camera
    // this step did not render from would keep drifting. Only the targets and their sources move
    // (lazy Adam, as SparseAdam for the hash grids).
    torch::NoGradGuard no_grad;
    std::vector<torch::Tensor> before;  // per scene [V, 6]
    for (const torch::Tensor& twist : camera_twists_) before.push_back(twist.detach().clone());
    SetLearningRates(camera_optimizer_.get(), {options_.lr_cameras}, decay);
    camera_optimizer_->step();
    std::vector<torch::Tensor> keep;  // per scene [V, 1]
    for (const torch::Tensor& twist : camera_twists_) keep.push_back(torch::zeros({twist.size(0), 1}, twist.options()));
    for (const auto& [scene, view] : touched) keep[scene][view] = 1.0;
    for (size_t i = 0; i < camera_twists_.size(); ++i) {
      camera_twists_[i].copy_(before[i] + (camera_twists_[i].detach() - before[i]) * keep[i]);
    }
  }
  ++step_;
  return result;
}

DbarfStepResult DbarfTrainer::TrainOnSample(uint64_t seed, DbarfStage stage, double weight, bool* rgb_valid_out,
                                            std::vector<std::pair<int, int>>* touched) {
  DbarfStepResult result;
  result.stage = stage;
  std::mt19937_64 rng(seed);
  torch::manual_seed(rng());
  const auto [s, t] = targets_[std::uniform_int_distribution<size_t>(0, targets_.size() - 1)(rng)];
  const DbarfScene& scene = scenes_[s];
  const int jitter = std::uniform_int_distribution<int>(options_.source_jitter_min, options_.source_jitter_max)(rng);
  // At least 2: a rendered sample needs two views that see it (ibr_render.h).
  std::vector<int> sources = SourcesOf(scene, t, std::max(2, options_.num_sources + jitter));
  std::shuffle(sources.begin(), sources.end(), rng);
  if (sources.size() > 1 && std::uniform_real_distribution<double>(0, 1)(rng) < options_.self_source_probability) {
    sources.back() = t;
  }
  result.scene = s;
  result.target = t;
  result.num_sources = static_cast<int>(sources.size());

  const torch::Tensor src_idx =
      torch::tensor(std::vector<int64_t>(sources.begin(), sources.end()), torch::kLong).to(scene.images.device());
  const torch::Tensor target = scene.images.slice(0, t, t + 1);               // [1, 3, H, W]
  const torch::Tensor source_images = scene.images.index_select(0, src_idx);  // [N, 3, H, W]
  const torch::Tensor k_t = scene.intrinsics[t];                              // [3, 3]
  const bool pose_grad = result.stage != DbarfStage::kNerf;
  const bool nerf_on = result.stage != DbarfStage::kPose;
  model_->pose_net->SetDepthRange(scene.near, scene.far);
  const torch::Tensor cameras = Cameras(s);  // [V, 4, 4], with gradients to the twists when refined

  // The pose network (with gradients only where the pose optimiser steps).
  PoseDepthPrediction pred;
  torch::Tensor src_from_tgt;  // [N, 4, 4]
  if (pose_grad || options_.nerf_poses == "network") {
    torch::AutoGradMode grad(pose_grad);
    torch::Tensor init =
        options_.pose_init == "cameras" ? RelativeCameras(cameras.detach(), t, sources) : torch::Tensor();
    if (pose_grad && init.defined() && (options_.init_noise_deg > 0 || options_.init_noise_translation > 0)) {
      init = PerturbRelativePoses(init, options_.init_noise_deg, options_.init_noise_translation);
    }
    torch::Tensor pose_input = target;  // [1, 3, H, W]
    if (options_.blur_probability > 0 &&
        std::uniform_real_distribution<double>(0, 1)(rng) < options_.blur_probability) {
      pose_input = BoxBlur(target, std::uniform_int_distribution<int>(1, options_.blur_max_radius)(rng), 3);
    }
    pred = model_->pose_net->forward(pose_input, source_images, k_t, init);
    src_from_tgt = pred.src_from_tgt.back();
  }
  torch::Tensor loss = torch::zeros({}, torch::kFloat);
  if (pose_grad) {
    const SfmLossResult sfm = SfmLoss(target, source_images, pred.inv_depths, pred.src_from_tgt, k_t, options_.sfm);
    result.sfm_loss = sfm.total.item<double>();
    loss = result.stage == DbarfStage::kJoint ? std::pow(2.0, -options_.joint_decay * step_) * sfm.total : sfm.total;
    {
      torch::NoGradGuard no_grad;
      const double lo = 1.0 / scene.far, hi = 1.0 / scene.near;
      result.disparity = ((pred.inv_depths.back() - lo) / (hi - lo)).mean().item<double>();
      if (scene.supervision_cam_from_world.defined()) {
        const torch::Tensor truth = RelativeCameras(scene.supervision_cam_from_world, t, sources);  // [N, 4, 4]
        const torch::Tensor last = pred.src_from_tgt.back().detach();                               // [N, 4, 4]
        result.rotation_err_deg = RotationAngleDeg(last, truth).mean().item<double>();
        const torch::Tensor tp = last.slice(1, 0, 3).select(2, 3), tg = truth.slice(1, 0, 3).select(2, 3);  // [N, 3]
        const torch::Tensor norms = tp.norm(2, 1), true_norms = tg.norm(2, 1).clamp_min(1e-9);
        const torch::Tensor cosine = (tp * tg).sum(1) / (norms * true_norms).clamp_min(1e-12);
        result.direction_err_deg = (torch::acos(cosine.clamp(-1, 1)) * (180.0 / M_PI)).mean().item<double>();
        // Of the sums: a source that is the target itself (no baseline) does not blow it up.
        result.translation_ratio = (norms.sum() / true_norms.sum()).item<double>();
      }
    }
    if (options_.supervise_poses > 0) {
      const torch::Tensor pose_loss =
          SupervisedPoseLoss(pred.src_from_tgt, RelativeCameras(scene.supervision_cam_from_world, t, sources),
                             options_.supervise_rotation_weight);
      result.pose_loss = pose_loss.item<double>();
      loss = loss + options_.supervise_poses * pose_loss;
    }
    if (options_.supervise_depth > 0) {
      const torch::Tensor truth = RelativeCameras(scene.supervision_cam_from_world, t, sources);  // [N, 4, 4]
      const std::vector<torch::Tensor> true_poses(pred.inv_depths.size(), truth);
      const SfmLossResult depth_sfm = SfmLoss(target, source_images, pred.inv_depths, true_poses, k_t, options_.sfm);
      loss = loss + options_.supervise_depth * depth_sfm.total;
    }
  }
  bool rgb_valid = false;
  if (nerf_on) {
    if (result.stage == DbarfStage::kNerf) {
      src_from_tgt = options_.nerf_poses == "cameras" ? RelativeCameras(cameras, t, sources) : src_from_tgt.detach();
    }
    const IbrSourceViews views =
        model_->nerf.PrepareSources(source_images, scene.intrinsics.index_select(0, src_idx), src_from_tgt);
    const int64_t height = scene.images.size(2), width = scene.images.size(3);
    const int64_t num_rays = std::max<int64_t>(
        1, std::min<int64_t>(height * width, options_.rays_per_step * 5 / static_cast<int64_t>(sources.size())));
    const torch::Tensor pixels = torch::randperm(height * width, torch::kLong).slice(0, 0, num_rays).to(k_t.device());
    const IbrRays rays = TargetRays(k_t, torch::eye(4, k_t.options()), height, width, pixels);
    const IbrRenderOutput out = model_->nerf.RenderRays(views, rays, scene.near, scene.far, /*training=*/true);
    const torch::Tensor gt = target[0].reshape({3, -1}).t().index_select(0, pixels);  // [R, 3]
    const torch::Tensor mask = out.valid.to(torch::kFloat).unsqueeze(1);
    const double num_valid = mask.sum().item<double>();
    if (num_valid > 0) {
      const torch::Tensor rgb_loss = ((out.rgb - gt).pow(2) * mask).sum() / (3.0 * num_valid);
      result.rgb_loss = rgb_loss.item<double>();
      result.psnr = -10.0 * std::log10(std::max(result.rgb_loss, 1e-10));
      const double a = result.stage == DbarfStage::kJoint ? std::pow(2.0, -options_.joint_decay * step_) : 0.0;
      loss = loss + (1.0 - a) * rgb_loss;
      rgb_valid = true;
    }
  }
  if (!std::isfinite(loss.item<double>())) {
    throw std::runtime_error("non-finite loss at step " + std::to_string(step_) + " (" + DbarfStageName(result.stage) +
                             " stage, scene " + scene.name + ", target " + scene.image_names[t] + ")");
  }
  if (loss.requires_grad()) (weight * loss).backward();
  if (nerf_on && rgb_valid) {
    touched->push_back({s, t});
    for (int j : sources) touched->push_back({s, j});
  }
  *rgb_valid_out = rgb_valid;
  return result;
}

void DbarfTrainer::SaveState(const std::string& path) const {
  const Json meta = {{"format", kStateFormat}, {"version", kStateVersion}, {"step", step_}};
  std::ostringstream rng;
  rng << rng_;
  torch::serialize::OutputArchive archive, nerf, pose;
  archive.write("meta", StringTensor(meta.dump()));
  archive.write("rng", StringTensor(rng.str()));
  nerf_optimizer_->save(nerf);
  pose_optimizer_->save(pose);
  archive.write("nerf_optimizer", nerf);
  archive.write("pose_optimizer", pose);
  if (camera_optimizer_) {
    torch::serialize::OutputArchive cameras;
    camera_optimizer_->save(cameras);
    archive.write("camera_optimizer", cameras);
    for (size_t s = 0; s < camera_twists_.size(); ++s) {
      archive.write("camera_twists_" + std::to_string(s), camera_twists_[s].detach());
    }
  }
  SaveArchiveAtomic(archive, path);
}

void DbarfTrainer::LoadState(const std::string& path) {
  torch::serialize::InputArchive archive;
  const Json meta = LoadArchiveMeta(path, "DBARF training state", kStateFormat, kStateVersion, &archive);
  const JsonField m(meta, path);
  try {
    torch::Tensor rng;
    archive.read("rng", rng);
    std::istringstream in(TensorString(rng));
    in >> rng_;
    if (!in) ThrowInputError(path, "rng", "a random-generator state");
    torch::serialize::InputArchive nerf, pose;
    archive.read("nerf_optimizer", nerf);
    archive.read("pose_optimizer", pose);
    nerf_optimizer_->load(nerf);
    pose_optimizer_->load(pose);
    const torch::Device device = scenes_.front().images.device();  // the state was read on the CPU
    MoveOptimizerState(*nerf_optimizer_, device);
    MoveOptimizerState(*pose_optimizer_, device);
    if (camera_optimizer_) {
      torch::serialize::InputArchive cameras;
      archive.read("camera_optimizer", cameras);
      camera_optimizer_->load(cameras);
      MoveOptimizerState(*camera_optimizer_, device);
      for (size_t s = 0; s < camera_twists_.size(); ++s) {
        torch::Tensor twist;
        archive.read("camera_twists_" + std::to_string(s), twist);
        if (twist.sizes() != camera_twists_[s].sizes()) ThrowInputError(path, "camera_twists", "one twist per image");
        torch::NoGradGuard no_grad;
        camera_twists_[s].copy_(twist);
      }
    }
  } catch (const c10::Error&) {
    ThrowInputError(path, "", "a complete DBARF training state for this configuration");
  }
  step_ = m["step"].Int();
}

void DbarfRunOptions::Check() const {
  if (steps < 1) throw InputError("--steps: expected >= 1, got " + std::to_string(steps));
  if (checkpoint_every < 1)
    throw InputError("--checkpoint-every: expected >= 1, got " + std::to_string(checkpoint_every));
  if (out.empty()) throw InputError("--out: expected a weights path");
}

DbarfRunResult RunDbarfTraining(DbarfModel* model, std::vector<DbarfScene> scenes, const DbarfTrainOptions& options,
                                const DbarfRunOptions& run, DistGroup* group) {
  run.Check();
  model->To(run.device);
  for (DbarfScene& scene : scenes) scene = DbarfSceneTo(scene, run.device);
  DbarfTrainer trainer(model, std::move(scenes), options, group);
  const bool is_main = trainer.group().is_main();
  const std::string state_path = run.out + ".train";
  if (run.resume) {
    if (!FileExists(state_path))
      ThrowInputError(state_path, "", "a training state to resume (written by dbarf pretrain / finetune)");
    trainer.LoadState(state_path);
    LOG_INFO("resuming {} at step {}", run.out, trainer.step());
  }
  const double seconds_before = model->training.is_object() && model->training.contains("seconds") &&
                                        model->training["seconds"].is_number() && run.resume
                                    ? model->training["seconds"].get<double>()
                                    : 0.0;
  std::ofstream log;
  if (is_main) {
    if (run.resume) RewindTrainingLog(run.out + ".log.jsonl", trainer.step());
    log.open(run.out + ".log.jsonl", run.resume ? std::ios::app : std::ios::trunc);
  }
  ProgressBar bar("dbarf train", run.steps, "step");
  bar.Resume(trainer.step());
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  std::vector<double> psnrs, sfms;
  const auto checkpoint = [&] {
    if (!is_main) return;
    model->training["steps"] = trainer.step();
    model->training["seconds"] = seconds_before + elapsed();
    model->training["scenes"] = trainer.scenes().size();
    model->training["schedule"] = options.schedule;
    model->training["stage_steps"] = options.stage_steps;
    model->training["samples_per_step"] = trainer.samples_per_step();
    model->training["processes"] = trainer.group().world_size();
    SaveDbarfWeights(*model, run.out);
    trainer.SaveState(state_path);
  };
  while (trainer.step() < run.steps) {
    const DbarfStepResult r = trainer.Step();
    if (r.psnr > 0) psnrs.push_back(r.psnr);
    if (r.sfm_loss > 0) sfms.push_back(r.sfm_loss);
    Json line = {{"step", trainer.step()}, {"stage", DbarfStageName(r.stage)}, {"scene", r.scene},
                 {"target", r.target},     {"sources", r.num_sources},         {"seconds", elapsed()}};
    if (r.sfm_loss > 0) line["sfm_loss"] = r.sfm_loss;
    if (r.rgb_loss > 0) line["rgb_loss"] = r.rgb_loss, line["psnr"] = r.psnr;
    if (r.pose_loss > 0) line["pose_loss"] = r.pose_loss;
    if (r.disparity >= 0) line["disparity"] = r.disparity;
    if (r.rotation_err_deg >= 0) {
      line["rot_err_deg"] = r.rotation_err_deg;
      line["dir_err_deg"] = r.direction_err_deg;
      line["t_ratio"] = r.translation_ratio;
    }
    if (is_main) log << line.dump() << "\n";
    if (r.psnr > 0) bar.SetMetric("psnr", r.psnr);
    if (r.sfm_loss > 0) bar.SetMetric("sfm", r.sfm_loss);
    if (r.pose_loss > 0) bar.SetMetric("pose", r.pose_loss);
    bar.Tick();
    if (trainer.step() % run.checkpoint_every == 0 || trainer.step() == run.steps) {
      if (is_main) log.flush();
      checkpoint();
    }
  }
  bar.Finish();
  DbarfRunResult result;
  result.steps = trainer.step();
  result.seconds = elapsed();
  const auto tail_mean = [](const std::vector<double>& v) {
    if (v.empty()) return 0.0;
    const size_t n = std::max<size_t>(1, v.size() / 10);
    double sum = 0;
    for (size_t i = v.size() - n; i < v.size(); ++i) sum += v[i];
    return sum / n;
  };
  result.mean_psnr_last = tail_mean(psnrs);
  result.mean_sfm_last = tail_mean(sfms);
  torch::NoGradGuard no_grad;
  for (size_t s = 0; s < trainer.scenes().size(); ++s) {
    const torch::Tensor c = trainer.Cameras(static_cast<int>(s));
    result.cameras.push_back(c.defined() ? c.detach().cpu().clone() : c);
  }
  return result;
}

namespace {

// Errors of predicted relative poses (one call per target) accumulated over a scene.
struct PoseErrorSum {
  double rot = 0, trans = 0, dir = 0, norm = 0, true_norm = 0, disparity = 0;
  int targets = 0;
  RelativePoseError e;
  void Add(const torch::Tensor& p, const torch::Tensor& g) {
    rot += RotationAngleDeg(p, g).sum().item<double>();
    const torch::Tensor tp = p.slice(1, 0, 3).select(2, 3), tg = g.slice(1, 0, 3).select(2, 3);  // [N, 3]
    trans += (tp - tg).norm(2, 1).sum().item<double>();
    norm += tp.norm(2, 1).sum().item<double>();
    true_norm += tg.norm(2, 1).sum().item<double>();
    const torch::Tensor cosine = (tp * tg).sum(1) / (tp.norm(2, 1) * tg.norm(2, 1)).clamp_min(1e-12);
    dir += (torch::acos(cosine.clamp(-1, 1)) * (180.0 / M_PI)).sum().item<double>();
    e.pairs += static_cast<int>(p.size(0));
  }
  RelativePoseError Result() {
    if (e.pairs > 0) {
      e.rotation_deg = rot / e.pairs;
      e.translation = trans / e.pairs;
      e.translation_deg = dir / e.pairs;
      e.translation_ratio = true_norm > 0 ? norm / true_norm : 0;
    }
    if (targets > 0) e.disparity = disparity / targets;
    return e;
  }
};

// The initial relative poses of target t: the scene's cameras, perturbed by a draw that depends
// only on (noise.seed, t), so cameras and network see the same initialisation.
torch::Tensor InitialRelativePoses(const DbarfScene& scene, int t, const std::vector<int>& sources,
                                   const RelativePoseNoise& noise) {
  const torch::Tensor cameras = RelativeCameras(scene.cam_from_world, t, sources);
  if (!noise.Active()) return cameras;
  at::Generator generator = at::detail::createCPUGenerator(noise.seed * 1000003ULL + static_cast<uint64_t>(t));
  return PerturbRelativePoses(cameras, noise.deg, noise.translation, generator);
}

}  // namespace

RelativePoseError EvaluateCameraRelativePoses(const DbarfScene& scene, const torch::Tensor& true_cam_from_world,
                                              int num_sources, const RelativePoseNoise& noise) {
  PoseErrorSum sum;
  for (int t = 0; t < scene.NumViews(); ++t) {
    if (!scene.usable[t]) continue;
    const std::vector<int> sources = DbarfTrainer::SourcesOf(scene, t, num_sources);
    if (!sources.empty()) {
      sum.Add(InitialRelativePoses(scene, t, sources, noise), RelativeCameras(true_cam_from_world, t, sources));
    }
  }
  return sum.Result();
}

RelativePoseError EvaluateIdentityRelativePoses(const DbarfScene& scene, const torch::Tensor& true_cam_from_world,
                                                int num_sources) {
  PoseErrorSum sum;
  for (int t = 0; t < scene.NumViews(); ++t) {
    if (!scene.usable[t]) continue;
    const std::vector<int> sources = DbarfTrainer::SourcesOf(scene, t, num_sources);
    if (!sources.empty()) {
      const int64_t n = static_cast<int64_t>(sources.size());
      sum.Add(torch::eye(4, true_cam_from_world.options()).expand({n, 4, 4}),
              RelativeCameras(true_cam_from_world, t, sources));
    }
  }
  return sum.Result();
}

RelativePoseError EvaluateRelativePoses(DbarfModel& model, const DbarfScene& scene,
                                        const torch::Tensor& true_cam_from_world, int num_sources,
                                        const std::string& pose_init, const RelativePoseNoise& noise) {
  torch::NoGradGuard no_grad;
  model.Train(false);
  model.pose_net->SetDepthRange(scene.near, scene.far);
  PoseErrorSum sum;
  for (int t = 0; t < scene.NumViews(); ++t) {
    if (!scene.usable[t]) continue;
    const std::vector<int> sources = DbarfTrainer::SourcesOf(scene, t, num_sources);
    if (sources.empty()) continue;
    // The scene may sit on another device than the model: its inputs go to the model's, the
    // prediction comes back.
    const torch::Device device = model.Device();
    const torch::Tensor idx =
        torch::tensor(std::vector<int64_t>(sources.begin(), sources.end()), torch::kLong).to(scene.images.device());
    torch::Tensor init = pose_init == "cameras" ? InitialRelativePoses(scene, t, sources, noise) : torch::Tensor();
    if (init.defined()) init = init.to(device);
    const auto pred =
        model.pose_net->forward(scene.images.slice(0, t, t + 1).to(device),
                                scene.images.index_select(0, idx).to(device), scene.intrinsics[t].to(device), init);
    sum.Add(pred.src_from_tgt.back().to(true_cam_from_world.device()),
            RelativeCameras(true_cam_from_world, t, sources));
    const double lo = 1.0 / scene.far, hi = 1.0 / scene.near;
    sum.disparity += ((pred.inv_depths.back() - lo) / (hi - lo)).mean().item<double>();
    ++sum.targets;
  }
  return sum.Result();
}

}  // namespace nerfreg
