// The pose stage's self-supervised SfM loss (dbarf/sfm_loss.h) around the truth (issue 45): for
// every training view of rendered scenes (nerfreg render --depth, so the true z-depth is known),
// its sources chosen as training chooses them (DbarfTrainer::SourcesOf, 5), the loss at the true
// relative poses and depth against other poses and depths: a constant depth, the static solution
// (identity poses, depth at the far bound), the true rotation with the translation scaled. Scenes
// are loaded as training loads them (--scene-cameras ground-truth: the normalised frame and the
// widened near / far), so the figures are the ones the trainer's loss would give. Prints a Markdown
// table (means over targets) and, with --png DIR, writes per scene a strip of the first target:
// target | its first source | that source warped at the truth | 4 |warped - target| | the auto-mask
// (white where the un-warped source wins) at the truth | the same at the identity. Then the
// gradient's direction at the static solution and near it, and the loss along the geodesic from the
// identity to the truth at several depths. With --optimise N (of every --optimise-every n-th view,
// default 4; the other views are skipped), the same loss optimised directly from the identity and
// disparity 0.1 (no network: a twist per source, a coarse disparity map, Adam), per loss variant.
//   build/bench/nerfreg_sfm_loss_probe --png /tmp/probe data/llff/val_3001/transforms.json ...
//   build/bench/nerfreg_sfm_loss_probe --optimise 200 --optimise-every 10 data/llff/val_3002/transforms.json
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "nerfreg/data/npy.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/sfm_loss.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/util/image.h"

namespace nerfreg {
namespace {

namespace fs = std::filesystem;

// The scene frame's scale over the dataset's (UseGroundTruthCameras normalises the cameras).
double SceneScale(const LoadedDbarfScene& loaded) {
  const auto centre = [](const Rigid3d& c) { return Eigen::Vector3d(c.Inverse().translation); };
  double ds = 0, sc = 0;
  for (size_t i = 1; i < loaded.dataset.frames.size(); ++i) {
    ds += (centre(loaded.dataset.frames[i].cam_from_world) - centre(loaded.dataset.frames[0].cam_from_world)).norm();
    const Eigen::Matrix4d a = TensorToMatrix4(loaded.scene.cam_from_world[i]);
    const Eigen::Matrix4d b = TensorToMatrix4(loaded.scene.cam_from_world[0]);
    const Eigen::Vector3d ca = -a.topLeftCorner<3, 3>().transpose() * a.topRightCorner<3, 1>();
    const Eigen::Vector3d cb = -b.topLeftCorner<3, 3>().transpose() * b.topRightCorner<3, 1>();
    sc += (ca - cb).norm();
  }
  return sc / ds;
}

// The render's z-depth of frame i [1, 1, H, W] in the scene's units, 0 where no surface.
torch::Tensor TrueDepth(const LoadedDbarfScene& loaded, int i, double scale) {
  const Frame& f = loaded.dataset.frames[i];
  const fs::path image = loaded.dataset.ImagePath(f);
  const fs::path npy = image.parent_path().parent_path() / "depth" / (image.stem().string() + ".npy");
  const NpyArray a = ReadNpy(npy.string());
  const int64_t h = loaded.scene.images.size(2), w = loaded.scene.images.size(3);
  TORCH_CHECK(a.Size() == h * w, npy.string(), ": expected ", h * w, " depths");
  std::vector<float> v(a.data.begin(), a.data.end());
  return torch::tensor(v, torch::kFloat).view({1, 1, h, w}) * scale;
}

// The true relative poses [N, 4, 4] with their translations scaled by t_scale, or the identity
// (the static solution) where t_scale < 0.
torch::Tensor ScaledPoses(const torch::Tensor& truth, double t_scale) {
  if (t_scale < 0) return torch::eye(4).expand_as(truth).clone();
  torch::Tensor poses = truth.clone();
  poses.slice(1, 0, 3).select(2, 3) *= t_scale;
  return poses;
}

struct Config {
  std::string name;
  double t_scale = 1;  // the true translation times this (0: rotation only); < 0 identity poses
  std::string depth;   // "true", "median" (constant, the true median), "mid" (disparity 0.5), "far"
};

struct Sums {
  double photometric = 0, photometric_no_mask = 0, smoothness = 0, total = 0, identity_wins = 0, valid = 0;
  int n = 0;
};

// The photometric loss's gradient at poses [N, 4, 4] and a normalised disparity map [1, 1, H, W]
// (inverse depth lo + (hi - lo) d, as the network maps it): the cosines between the descent
// direction and the step to the truth, for the twist's translation and rotation parts (over the
// sources stacked) and for the disparity (the step to the true disparity, per pixel), and the mean
// descent direction of the disparity (> 0: the loss wants the depth nearer).
struct Gradient {
  double cos_translation = 0, cos_rotation = 0, cos_disparity = 0, disparity_push = 0;
};
Gradient GradientAt(const torch::Tensor& target, const torch::Tensor& src, const torch::Tensor& k,
                    const torch::Tensor& poses, const torch::Tensor& disparity, const torch::Tensor& truth,
                    const torch::Tensor& true_disparity, double lo, double hi, const SfmLossOptions& options) {
  const torch::Tensor xi = torch::zeros({poses.size(0), 6}).requires_grad_(true);
  const torch::Tensor d = disparity.clone().requires_grad_(true);
  const PhotometricLossResult r = PhotometricLoss(target, src, lo + (hi - lo) * d, Se3Update(xi, poses), k, options);
  r.loss.backward();
  // The left twist that takes the poses to the truth: truth = Exp(step) poses.
  const torch::Tensor step = Se3Log(Se3Compose(truth, Se3Inverse(poses)));  // [N, 6]
  const auto cosine = [](const torch::Tensor& a, const torch::Tensor& b) {
    return (a * b).sum().item<double>() / std::max(1e-20, a.norm().item<double>() * b.norm().item<double>());
  };
  Gradient g;
  g.cos_translation = cosine(-xi.grad().narrow(1, 0, 3), step.narrow(1, 0, 3));
  g.cos_rotation = cosine(-xi.grad().narrow(1, 3, 3), step.narrow(1, 3, 3));
  g.cos_disparity = cosine(-d.grad(), true_disparity - disparity);
  g.disparity_push = (-d.grad()).sum().item<double>() / std::max(1e-20, d.grad().abs().sum().item<double>());
  return g;
}

// Direct optimisation of the same loss, without the network: the relative poses (a left twist per
// source on the identity) and a coarse disparity map (16 x 12 logits, bilinearly upsampled,
// sigmoid), from the identity and disparity 0.1 (the untrained network's start), by Adam. Where
// true_inv_depth is defined the depth is held at it (poses only). Returns the rotation and
// direction errors (deg, means over sources), sum |t| / sum |t_true|, the mean disparity and the
// final photometric loss.
struct Optimised {
  double rotation_deg = 0, direction_deg = 0, translation_ratio = 0, disparity = 0, loss = 0;
};
Optimised OptimiseFromIdentity(const torch::Tensor& target, const torch::Tensor& src, const torch::Tensor& k,
                               const torch::Tensor& truth, double lo, double hi, const SfmLossOptions& options,
                               int steps, const torch::Tensor& true_inv_depth) {
  const int64_t n = src.size(0), h = target.size(2), w = target.size(3);
  torch::Tensor xi = torch::zeros({n, 6}).requires_grad_(true);
  torch::Tensor logits = torch::full({1, 1, 12, 16}, std::log(0.1 / 0.9)).requires_grad_(true);
  std::vector<torch::optim::OptimizerParamGroup> groups;
  groups.emplace_back(std::vector<torch::Tensor>{xi}, std::make_unique<torch::optim::AdamOptions>(5e-3));
  groups.emplace_back(std::vector<torch::Tensor>{logits}, std::make_unique<torch::optim::AdamOptions>(5e-2));
  torch::optim::Adam adam(groups, torch::optim::AdamOptions(5e-3));
  namespace F = torch::nn::functional;
  const auto disparity_of = [&]() {
    return torch::sigmoid(F::interpolate(
        logits,
        F::InterpolateFuncOptions().size(std::vector<int64_t>{h, w}).mode(torch::kBilinear).align_corners(false)));
  };
  double loss = 0;
  for (int i = 0; i < steps; ++i) {
    if (i == steps * 6 / 10 || i == steps * 8 / 10)
      for (auto& g : adam.param_groups())
        static_cast<torch::optim::AdamOptions&>(g.options())
            .lr(static_cast<torch::optim::AdamOptions&>(g.options()).lr() / 2);
    adam.zero_grad();
    const torch::Tensor inv = true_inv_depth.defined() ? true_inv_depth : lo + (hi - lo) * disparity_of();
    const SfmLossResult r = SfmLoss(target, src, {inv}, {Se3Exp(xi)}, k, options);
    r.total.backward();
    adam.step();
    loss = r.photometric[0].item<double>();
  }
  torch::NoGradGuard no_grad;
  const torch::Tensor pose = Se3Exp(xi);
  Optimised o;
  o.rotation_deg = (So3GeodesicAngle(pose, truth) * (180.0 / M_PI)).mean().item<double>();
  const torch::Tensor tp = pose.slice(1, 0, 3).select(2, 3), tg = truth.slice(1, 0, 3).select(2, 3);
  const torch::Tensor cosine = (tp * tg).sum(1) / (tp.norm(2, 1) * tg.norm(2, 1)).clamp_min(1e-12);
  o.direction_deg = (torch::acos(cosine.clamp(-1, 1)) * (180.0 / M_PI)).mean().item<double>();
  o.translation_ratio = (tp.norm(2, 1).sum() / tg.norm(2, 1).sum()).item<double>();
  o.disparity = true_inv_depth.defined() ? -1 : disparity_of().mean().item<double>();
  o.loss = loss;
  return o;
}

}  // namespace
}  // namespace nerfreg

int main(int argc, char** argv) {
  using namespace nerfreg;
  torch::set_num_threads(1);
  std::string png_dir;
  int optimise_steps = 0;  // --optimise N: direct optimisation from the identity, N Adam steps
  int optimise_every = 4;  // of every n-th training view
  std::vector<std::string> paths;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--png" && i + 1 < argc) {
      png_dir = argv[++i];
    } else if (a == "--optimise" && i + 1 < argc) {
      optimise_steps = std::stoi(argv[++i]);
    } else if (a == "--optimise-every" && i + 1 < argc) {
      optimise_every = std::stoi(argv[++i]);
    } else {
      paths.push_back(a);
    }
  }
  if (paths.empty()) {
    std::fprintf(stderr, "usage: %s [--png DIR] SCENE/transforms.json...\n", argv[0]);
    return 2;
  }
  if (!png_dir.empty()) fs::create_directories(png_dir);
  const std::vector<Config> configs = {
      {"truth, true depth", 1, "true"},
      {"truth, constant depth (true median)", 1, "median"},
      {"truth, disparity 0.5", 1, "mid"},
      {"truth, far bound", 1, "far"},
      {"identity, far bound (static)", -1, "far"},
      {"t x 0.5, true depth", 0.5, "true"},
      {"t x 0.1, true depth", 0.1, "true"},
      {"t x 0 (rotation only), true depth", 0, "true"},
      {"t x 0.05, far bound (collapsed)", 0.05, "far"},
  };
  const SfmLossOptions options;  // the trainer's (auto-mask on)
  SfmLossOptions no_mask = options;
  no_mask.auto_mask = false;
  std::map<std::string, Sums> all;
  // Gradient states: {name, translation scale (< 0 identity poses), disparity (< 0 the true one)}.
  struct State {
    std::string name;
    double t_scale, disparity;
  };
  const std::vector<State> states = {
      {"identity, disparity 0", -1, 0},
      {"identity, disparity 0.1", -1, 0.1},
      {"identity, disparity 0.3", -1, 0.3},
      {"identity, true disparity", -1, -1},
      {"truth, disparity 0 (far bound)", 1, 0},
      {"truth, disparity 0.1", 1, 0.1},
      {"t x 0.05, disparity 0 (collapsed)", 0.05, 0},
      {"t x 0.5, true disparity", 0.5, -1},
  };
  std::map<std::string, Gradient> grad_sums;
  // The loss along the geodesic from the identity to the truth (twist lambda log(truth)).
  const std::vector<double> lambdas = {0, 0.1, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5};
  std::map<std::string, std::vector<double>> profile;
  struct Variant {
    std::string name;
    bool auto_mask;
    double clip;
    bool true_depth;
  };
  const std::vector<Variant> variants = {{"poses and depth, auto-mask, clip 0.5 (the trainer's)", true, 0.5, false},
                                         {"poses only at the true depth, auto-mask, clip 0.5", true, 0.5, true},
                                         {"poses and depth, no auto-mask, clip 0.5", false, 0.5, false},
                                         {"poses and depth, no auto-mask, no clip", false, -1, false},
                                         {"poses and depth, auto-mask, no clip", true, -1, false}};
  std::map<std::string, Optimised> optimised;
  int optimised_targets = 0;
  double optimised_true_disparity = 0;
  double true_disparity_sum = 0;
  int gradient_targets = 0;
  for (const std::string& path : paths) {
    DbarfSceneOptions scene_options;
    scene_options.cameras = "ground-truth";
    const LoadedDbarfScene loaded = LoadDbarfScene(path, scene_options);
    const DbarfScene& scene = loaded.scene;
    const double scale = SceneScale(loaded);
    const double lo = 1.0 / scene.far, hi = 1.0 / scene.near;
    std::map<std::string, Sums> per_scene;
    double out_of_range = 0, pixels = 0;
    bool strip_written = false;
    for (int t = 0; t < scene.NumViews(); ++t) {
      if (!scene.usable[t]) continue;
      if (optimise_steps > 0 && t % optimise_every != 1) continue;  // the optimisation's targets alone
      const std::vector<int> sources = DbarfTrainer::SourcesOf(scene, t, 5);
      if (sources.empty()) continue;
      const torch::Tensor idx = torch::tensor(std::vector<int64_t>(sources.begin(), sources.end()), torch::kLong);
      const torch::Tensor target = scene.images.slice(0, t, t + 1);
      const torch::Tensor src = scene.images.index_select(0, idx);
      const torch::Tensor k = scene.intrinsics[t];
      const torch::Tensor truth = RelativeCameras(scene.cam_from_world, t, sources);  // [N, 4, 4]
      const torch::Tensor depth = TrueDepth(loaded, t, scale);
      const torch::Tensor surface = depth > 0;
      out_of_range += ((depth < scene.near) | (depth > scene.far)).logical_and(surface).sum().item<double>();
      pixels += surface.sum().item<double>();
      const torch::Tensor true_inv = torch::where(surface, 1.0 / depth.clamp_min(1e-6), torch::full_like(depth, lo));
      const double median_depth = depth.masked_select(surface).median().item<double>();
      const torch::Tensor true_disparity = ((true_inv - lo) / (hi - lo)).clamp(0, 1);
      true_disparity_sum += true_disparity.mean().item<double>();
      ++gradient_targets;
      for (const State& st : states) {
        const torch::Tensor poses = ScaledPoses(truth, st.t_scale);
        const torch::Tensor d = st.disparity < 0 ? true_disparity : torch::full_like(true_disparity, st.disparity);
        const Gradient g = GradientAt(target, src, k, poses, d, truth, true_disparity, lo, hi, options);
        Gradient& sum = grad_sums[st.name];
        sum.cos_translation += g.cos_translation;
        sum.cos_rotation += g.cos_rotation;
        sum.cos_disparity += g.cos_disparity;
        sum.disparity_push += g.disparity_push;
      }
      {
        torch::NoGradGuard no_grad;
        const torch::Tensor log_truth = Se3Log(truth);
        const std::vector<std::pair<std::string, torch::Tensor>> depths = {
            {"true depth", true_inv},
            {"far bound", torch::full_like(true_inv, lo)},
            {"constant (true median)", torch::full_like(true_inv, 1.0 / median_depth)},
            {"disparity 0.1", torch::full_like(true_inv, lo + 0.1 * (hi - lo))}};
        for (const auto& [name, inv] : depths) {
          std::vector<double>& row = profile[name];
          row.resize(lambdas.size());
          for (size_t i = 0; i < lambdas.size(); ++i)
            row[i] += PhotometricLoss(target, src, inv, Se3Exp(lambdas[i] * log_truth), k, options).loss.item<double>();
        }
      }
      if (optimise_steps > 0) {
        ++optimised_targets;
        optimised_true_disparity += true_disparity.mean().item<double>();
        for (const Variant& v : variants) {
          SfmLossOptions o = options;
          o.auto_mask = v.auto_mask;
          o.clip_std_factor = v.clip;
          const Optimised r = OptimiseFromIdentity(target, src, k, truth, lo, hi, o, optimise_steps,
                                                   v.true_depth ? true_inv : torch::Tensor());
          Optimised& sum = optimised[v.name];
          sum.rotation_deg += r.rotation_deg;
          sum.direction_deg += r.direction_deg;
          sum.translation_ratio += r.translation_ratio;
          sum.disparity += r.disparity;
          sum.loss += r.loss;
          std::fprintf(stderr, "%s t%d %s: rot %.3f dir %.1f |t| %.3f disp %.3f loss %.4f\n", path.c_str(), t,
                       v.name.c_str(), r.rotation_deg, r.direction_deg, r.translation_ratio, r.disparity, r.loss);
        }
      }
      torch::Tensor strip_truth_mask, strip_identity_mask, strip_warped;
      for (const Config& c : configs) {
        const torch::Tensor poses = ScaledPoses(truth, c.t_scale);
        torch::Tensor inv = true_inv;
        if (c.depth == "median") inv = torch::full_like(true_inv, 1.0 / median_depth);
        if (c.depth == "mid") inv = torch::full_like(true_inv, lo + 0.5 * (hi - lo));
        if (c.depth == "far") inv = torch::full_like(true_inv, lo);
        const PhotometricLossResult r = PhotometricLoss(target, src, inv, poses, k, options);
        const PhotometricLossResult r0 = PhotometricLoss(target, src, inv, poses, k, no_mask);
        // Which pixels the un-warped sources win (the auto-mask drops them).
        torch::Tensor warped_err = ClipErrorMaps(PhotometricErrorMap(r.warped, target), options.clip_std_factor);
        warped_err = torch::where(r.valid > 0.5, warped_err, torch::full_like(warped_err, kInvalidError));
        const torch::Tensor id_err = ClipErrorMaps(PhotometricErrorMap(src, target), options.clip_std_factor);
        const torch::Tensor wins = std::get<0>(id_err.min(0, true)) < std::get<0>(warped_err.min(0, true));
        const SfmLossResult full =
            SfmLoss(target, src, std::vector<torch::Tensor>(4, inv), std::vector<torch::Tensor>(4, poses), k, options);
        for (auto* s : {&per_scene[c.name], &all[c.name]}) {
          s->photometric += r.loss.item<double>();
          s->photometric_no_mask += r0.loss.item<double>();
          s->smoothness += full.smoothness[0].item<double>();
          s->total += full.total.item<double>();
          s->identity_wins += wins.to(torch::kFloat).mean().item<double>();
          s->valid += r.valid.mean().item<double>();
          ++s->n;
        }
        if (c.name == "truth, true depth") {
          strip_truth_mask = wins.to(torch::kFloat)[0].expand({3, -1, -1});
          strip_warped = r.warped[0];
        }
        if (c.t_scale < 0) strip_identity_mask = wins.to(torch::kFloat)[0].expand({3, -1, -1});
      }
      if (!png_dir.empty() && !strip_written) {
        const torch::Tensor diff = ((strip_warped - target[0]).abs() * 4).clamp(0, 1);
        const torch::Tensor strip =
            torch::cat({target[0], src[0], strip_warped, diff, strip_truth_mask, strip_identity_mask}, 2);
        const std::string name = fs::path(path).parent_path().filename().string();
        WriteImage((fs::path(png_dir) / (name + "_t" + std::to_string(t) + ".png")).string(), TensorToImage(strip));
        strip_written = true;
      }
    }
    std::printf("\n%s: near %.3f far %.3f (scene units, scale %.4f), true depth outside [near, far]: %.2f %%\n",
                path.c_str(), scene.near, scene.far, scale, 100.0 * out_of_range / std::max(pixels, 1.0));
    for (const Config& c : configs) {
      const Sums& s = per_scene[c.name];
      std::printf("  %-36s photometric %.4f  no-mask %.4f  total %.4f  identity wins %.3f\n", c.name.c_str(),
                  s.photometric / s.n, s.photometric_no_mask / s.n, s.total / s.n, s.identity_wins / s.n);
    }
  }
  std::printf(
      "\n| configuration | photometric (auto-mask) | photometric (no mask) | smoothness | total (4 predictions) "
      "| un-warped source wins | valid |\n|---|---|---|---|---|---|---|\n");
  for (const Config& c : configs) {
    const Sums& s = all[c.name];
    std::printf("| %s | %.4f | %.4f | %.3f | %.4f | %.3f | %.3f |\n", c.name.c_str(), s.photometric / s.n,
                s.photometric_no_mask / s.n, s.smoothness / s.n, s.total / s.n, s.identity_wins / s.n, s.valid / s.n);
  }
  std::printf("(%d targets; mean true normalised disparity %.3f)\n", all[configs[0].name].n,
              true_disparity_sum / std::max(1, gradient_targets));
  std::printf(
      "\nDescent direction against the step to the truth (cosines, means over targets):\n\n"
      "| state | translation | rotation | disparity | disparity push (> 0 nearer) |\n|---|---|---|---|---|\n");
  for (const State& st : states) {
    const Gradient& g = grad_sums[st.name];
    const double n = std::max(1, gradient_targets);
    std::printf("| %s | %.3f | %.3f | %.3f | %.3f |\n", st.name.c_str(), g.cos_translation / n, g.cos_rotation / n,
                g.cos_disparity / n, g.disparity_push / n);
  }
  if (optimised_targets > 0) {
    std::printf(
        "\nDirect optimisation from the identity, disparity 0.1, %d Adam steps, %d targets (true mean "
        "disparity %.3f):\n\n| variant | rotation (deg) | direction (deg) | |t| / |t_true| | disparity | "
        "photometric loss |\n|---|---|---|---|---|---|\n",
        optimise_steps, optimised_targets, optimised_true_disparity / optimised_targets);
    for (const Variant& v : variants) {
      const Optimised& o = optimised[v.name];
      const double n = optimised_targets;
      std::printf("| %s | %.3f | %.1f | %.3f | %.3f | %.4f |\n", v.name.c_str(), o.rotation_deg / n,
                  o.direction_deg / n, o.translation_ratio / n, o.disparity / n, o.loss / n);
    }
  }
  std::printf("\nPhotometric loss (auto-mask) along Exp(lambda log(truth)), means over targets:\n\n| depth |");
  for (double l : lambdas) std::printf(" %.2f |", l);
  std::printf("\n|---|");
  for (size_t i = 0; i < lambdas.size(); ++i) std::printf("---|");
  std::printf("\n");
  for (const auto& [name, row] : profile) {
    std::printf("| %s |", name.c_str());
    for (double v : row) std::printf(" %.4f |", v / std::max(1, gradient_targets));
    std::printf("\n");
  }
  return 0;
}
