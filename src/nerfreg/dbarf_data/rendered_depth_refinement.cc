#include "nerfreg/dbarf_data/rendered_depth_refinement.h"

#include <fmt/format.h>

#include <string>
#include <tuple>
#include <utility>

#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

void RenderedDepthRefinementOptions::Check() const {
  if (rounds < 0) throw InputError("--depth-ba-rounds: expected >= 0, got " + std::to_string(rounds));
  if (num_sources < 1) throw InputError("--depth-ba-sources: expected >= 1, got " + std::to_string(num_sources));
  if (max_width < 0) throw InputError("--depth-ba-max-width: expected >= 0, got " + std::to_string(max_width));
  if (view_range_margin != 0 && !(view_range_margin > 1))
    throw InputError(fmt::format("--depth-ba-view-range: expected 0 or > 1, got {:g}", view_range_margin));
  if (ba.iterations_per_level < 1)
    throw InputError("--depth-ba-steps: expected >= 1, got " + std::to_string(ba.iterations_per_level));
  ba.Check();
}

namespace {

// Mean distance of the usable cameras' centres to the fixed one's.
double MeanDistanceToFixed(const torch::Tensor& cam_from_world, const std::vector<bool>& usable, int fixed) {
  const torch::Tensor c = cam_from_world.to(torch::kDouble);
  const torch::Tensor centres =
      -torch::matmul(c.slice(1, 0, 3).slice(2, 0, 3).transpose(1, 2), c.slice(1, 0, 3).slice(2, 3, 4)).squeeze(-1);
  double sum = 0;
  int count = 0;
  for (int v = 0; v < static_cast<int>(usable.size()); ++v) {
    if (!usable[v] || v == fixed) continue;
    sum += (centres[v] - centres[fixed]).norm().item<double>();
    ++count;
  }
  return count > 0 ? sum / count : 0.0;
}

// Inverse depth [1, H, W] of a render: 1 / z where valid, the median elsewhere, within the range.
torch::Tensor InverseDepthOf(const NovelView& view, double near, double far) {
  torch::Tensor inv = 1.0 / view.depth.clamp(near, far);  // [H, W]
  const torch::Tensor valid = view.valid & torch::isfinite(view.depth);
  const double fill = valid.any().item<bool>() ? inv.masked_select(valid).median().item<double>() : 2.0 / (near + far);
  return torch::where(valid, inv, torch::full_like(inv, fill)).unsqueeze(0);
}

}  // namespace

RenderedDepthRefinementResult RefineCamerasWithRenderedDepths(DbarfModel& model, const DbarfScene& scene,
                                                              const torch::Tensor& cam_from_world,
                                                              const RenderedDepthRefinementOptions& options) {
  options.Check();
  const int64_t v = scene.NumViews();
  TORCH_CHECK(cam_from_world.sizes() == torch::IntArrayRef({v, 4, 4}),
              "RefineCamerasWithRenderedDepths: cam_from_world must be [V, 4, 4]");
  const Timer timer;
  RenderedDepthRefinementResult result;
  // The BA runs on the CPU (the renderer on the model's device): the cameras and images come here.
  result.cam_from_world = cam_from_world.to(torch::kCPU, torch::kFloat).clone();
  int fixed = -1;
  for (int64_t k = 0; k < v && fixed < 0; ++k)
    if (scene.usable[k]) fixed = static_cast<int>(k);
  if (fixed < 0 || options.rounds == 0) return result;
  const double distance = MeanDistanceToFixed(result.cam_from_world, scene.usable, fixed);
  // The depths are rendered, and the warps run, at max_width at most; the cameras do not depend
  // on the size.
  const auto [images, intrinsics] =
      ShrinkToWidth(scene.images.cpu(), scene.intrinsics.cpu(), options.max_width);  // [V, 3, h, w], [V, 3, 3]
  const int64_t height = images.size(2), width = images.size(3);

  ProgressBar bar("depth BA", v * options.rounds, "view");
  for (int round = 0; round < options.rounds; ++round) {
    DbarfScene placed = scene;  // the renderer places its sources by the current cameras
    placed.cam_from_world = result.cam_from_world.to(scene.images.device());
    std::vector<torch::Tensor> inv_depths;  // per view [1, H, W]
    std::vector<std::pair<int, int>> pairs;
    for (int64_t t = 0; t < v; ++t) {
      std::vector<int> sources;
      for (int s : NearestViews(placed, placed.cam_from_world[t], options.num_sources + 1))
        if (s != t && static_cast<int>(sources.size()) < options.num_sources) sources.push_back(s);
      if (sources.empty()) {
        inv_depths.push_back(torch::full({1, height, width}, 2.0 / (scene.near + scene.far)));
        bar.Tick();
        continue;
      }
      NovelView view = RenderNovelView(model, placed, sources, intrinsics[t], placed.cam_from_world[t], height, width);
      if (options.view_range_margin > 0) {
        DbarfScene narrowed = placed;
        std::tie(narrowed.near, narrowed.far) =
            ViewDepthRange(view.depth, view.valid, scene.near, scene.far, options.view_range_margin);
        view = RenderNovelView(model, narrowed, sources, intrinsics[t], placed.cam_from_world[t], height, width);
      }
      inv_depths.push_back(InverseDepthOf(view, scene.near, scene.far));
      for (int s : sources) pairs.push_back({static_cast<int>(t), s});
      bar.Tick();
    }
    const PhotometricBundleAdjustmentResult ba = PhotometricBundleAdjust(
        images, intrinsics, torch::stack(inv_depths), result.cam_from_world, pairs, fixed, options.ba);
    torch::Tensor refined = ba.cam_from_world.to(torch::kFloat);
    // The scale gauge was free in the BA: back to the input's, which the depth range is in.
    const double after = MeanDistanceToFixed(refined, scene.usable, fixed);
    if (after > 0 && distance > 0) refined.slice(1, 0, 3).select(2, 3).mul_(distance / after);
    result.cam_from_world = refined;
    result.initial_loss.push_back(ba.initial_loss);
    result.final_loss.push_back(ba.final_loss);
    result.pairs = static_cast<int>(pairs.size());
    LOG_INFO("depth BA round {}: {} pairs, photometric error {:.4f} -> {:.4f} ({:.1f} s)", round + 1, pairs.size(),
             ba.initial_loss, ba.final_loss, ba.seconds);
  }
  bar.Finish();
  result.seconds = timer.Seconds();
  return result;
}

}  // namespace nerfreg
