// DBARF's self-supervised SfM loss (dbarf/sfm_loss.h) on a real render, loaded as training loads
// it (--scene-cameras ground-truth: the normalised frame, the widened depth range): at the true
// relative poses and the renderer's true depth the loss must be well below the static solution
// the pose training collapses to, below half the true translation and below the inverse relative
// poses, and the warp at the truth must reproduce the target. The loss's own tests use an analytic
// plane scene in the loss's conventions; this one crosses the renderer's, the dataset loader's and
// the warp's (pixel centres, cam_from_world direction, intrinsics at the loaded size, z-depth), so a
// mismatch between them fails here (issue 45). Here and not in dbarf_data because the learned-core
// build, which has dbarf_data, has no renderer.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "nerfreg/data/npy.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/sfm_loss.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

namespace fs = std::filesystem;

// An LLFF-like render (render --trajectory llff --procedural 3001 --depth), 6 views, no test views, anti-aliased as the
// training data.
std::string RenderLlffScene(const ScopedTempDir& dir) {
  RenderDatasetOptions opt;
  opt.trajectory = "llff";
  opt.views = 6;
  opt.test_every = 100;
  opt.trajectory_seed = 3001;
  opt.write_depth = true;
  const std::string out = dir.File("scene");
  RenderDataset(ProceduralLayeredScene(3001, SceneMaterial::kTextured), opt, out);
  return out;
}

struct Pair {
  torch::Tensor target, sources, intrinsics, truth, true_inv_depth;  // as PhotometricLoss takes them
  double far = 0;
};

// Target `t` and its 3 nearest sources of the scene loaded at max_width, with the renderer's
// z-depth of the target in the scene's (normalised) units, as inverse depth.
Pair LoadPair(const std::string& dir, int t, int max_width) {
  DbarfSceneOptions options;
  options.cameras = "ground-truth";
  options.max_width = max_width;
  const LoadedDbarfScene loaded = LoadDbarfScene(dir, options);
  const DbarfScene& scene = loaded.scene;
  const std::vector<int> sources = DbarfTrainer::SourcesOf(scene, t, 3);
  EXPECT_EQ(sources.size(), 3u);
  Pair p;
  p.target = scene.images.slice(0, t, t + 1);
  p.sources = scene.images.index_select(0, torch::tensor(std::vector<int64_t>(sources.begin(), sources.end())));
  p.intrinsics = scene.intrinsics[t];
  p.truth = RelativeCameras(scene.cam_from_world, t, sources);
  p.far = scene.far;
  // The frame's scale: a relative translation in the scene against the dataset's.
  const Rigid3d rel =
      loaded.dataset.frames[sources[0]].cam_from_world * loaded.dataset.frames[t].cam_from_world.Inverse();
  const double scale = p.truth[0].slice(0, 0, 3).select(1, 3).norm().item<double>() / rel.translation.norm();
  const NpyArray depth =
      ReadNpy(JoinPaths(dir, "depth/r_" + std::string(t < 10 ? "00" : "0") + std::to_string(t) + ".npy"));
  const int64_t h0 = depth.shape[0], w0 = depth.shape[1];
  const std::vector<float> z(depth.data.begin(), depth.data.end());
  torch::Tensor inv = 1.0 / (torch::tensor(z).view({1, 1, h0, w0}) * scale).clamp_min(1e-6);
  EXPECT_GT(torch::tensor(z).min().item<double>(), 0.0) << "every pixel sees a surface (the backdrop fills the view)";
  // Loaded smaller: the inverse depth area-averaged alike.
  inv = torch::nn::functional::interpolate(inv, torch::nn::functional::InterpolateFuncOptions()
                                                    .size(std::vector<int64_t>{p.target.size(2), p.target.size(3)})
                                                    .mode(torch::kArea));
  p.true_inv_depth = inv;
  return p;
}

double Loss(const Pair& p, const torch::Tensor& src_from_tgt, const torch::Tensor& inv_depth) {
  return PhotometricLoss(p.target, p.sources, inv_depth, src_from_tgt, p.intrinsics).loss.item<double>();
}

void ExpectTheTruthLowest(const Pair& p) {
  const double truth = Loss(p, p.truth, p.true_inv_depth);
  const torch::Tensor identity = torch::eye(4).expand_as(p.truth).contiguous();
  const double stationary = Loss(p, identity, torch::full_like(p.true_inv_depth, 1.0 / p.far));
  torch::Tensor half = p.truth.clone();
  half.slice(1, 0, 3).select(2, 3) *= 0.5;
  const double half_translation = Loss(p, half, p.true_inv_depth);
  const double inverse = Loss(p, Se3Inverse(p.truth), p.true_inv_depth);
  EXPECT_LT(truth, 0.5 * stationary);
  EXPECT_LT(truth, 0.5 * half_translation);
  EXPECT_LT(truth, 0.5 * inverse);
  // The warp at the truth reproduces the target but at occlusions: the median |difference| over
  // the pixels every source sees, against the un-warped sources'.
  const PhotometricLossResult r = PhotometricLoss(p.target, p.sources, p.true_inv_depth, p.truth, p.intrinsics);
  const torch::Tensor seen = (r.valid.amin(0) > 0.5).expand({p.sources.size(0), -1, -1});  // [N, H, W]
  const double warp_error = (r.warped - p.target).abs().mean(1).masked_select(seen).median().item<double>();
  const double static_error = (p.sources - p.target).abs().mean(1).median().item<double>();
  EXPECT_LT(warp_error, 0.25 * static_error);
  std::printf(
      "loss: truth %.4f, static %.4f, half translation %.4f, inverse %.4f; |warped - target| %.4f, "
      "|source - target| %.4f\n",
      truth, stationary, half_translation, inverse, warp_error, static_error);
}

TEST(SfmLossOnARender, LowestAtTheTruePosesAndDepth) {
  const ScopedTempDir dir;
  const std::string scene = RenderLlffScene(dir);
  ExpectTheTruthLowest(LoadPair(scene, 2, 0));
  // At half the size (the images and intrinsics scaled by the loader, as --max-width does).
  ExpectTheTruthLowest(LoadPair(scene, 2, 64));
}

}  // namespace
}  // namespace nerfreg
