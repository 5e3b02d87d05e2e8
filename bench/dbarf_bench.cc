// DBARF on 2 CPU threads, the CPU configuration at the shipped weights' image size (128x96):
// rendering one novel view from 8 sources (what dbarf render / eval do per view), and one
// pose/depth-network forward for a target and 4 sources (what refinement costs per view).
//   build/bench/nerfreg_dbarf_bench --benchmark_counters_tabular=true
// Weights are random: the cost does not depend on their values.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/ibr_render.h"
#include "nerfreg/dbarf/se3.h"

namespace nerfreg {
namespace {

constexpr int64_t kHeight = 96, kWidth = 128;

torch::Tensor Intrinsics() {
  return torch::tensor({110.0, 0.0, 64.0, 0.0, 110.0, 48.0, 0.0, 0.0, 1.0}, torch::kFloat).view({3, 3});
}

// Sources on a small forward-facing arc around a target at the identity.
torch::Tensor SourcePoses(int64_t n) {
  std::vector<torch::Tensor> poses;
  for (int64_t i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * static_cast<double>(i) / static_cast<double>(n);
    poses.push_back(
        Se3Exp(torch::tensor({0.15 * std::cos(a), 0.1 * std::sin(a), 0.0, 0.01 * std::sin(a), -0.01 * std::cos(a), 0.0},
                             torch::kFloat)
                   .unsqueeze(0)));
  }
  return torch::cat(poses, 0);
}

void BM_RenderNovelView(benchmark::State& state) {
  torch::set_num_threads(2);
  torch::manual_seed(0);
  const int64_t n = state.range(0);
  DbarfModel model(DbarfOptions::Cpu());
  model.Train(false);
  torch::NoGradGuard no_grad;
  IbrSourceViews views;
  views.images = torch::rand({n, 3, kHeight, kWidth});
  views.intrinsics = Intrinsics().unsqueeze(0).repeat({n, 1, 1});
  views.cam_from_world = SourcePoses(n);
  for (auto _ : state) {
    benchmark::DoNotOptimize(RenderIbrImage(model.nerf.feature_net, model.nerf.ibrnet, views, Intrinsics(),
                                            torch::eye(4), kHeight, kWidth, 1.0, 8.0, model.options.nerf.render));
  }
  state.counters["views/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["samples"] = static_cast<double>(model.options.nerf.render.num_samples);
}
BENCHMARK(BM_RenderNovelView)->Arg(8)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_PoseDepthForward(benchmark::State& state) {
  torch::set_num_threads(2);
  torch::manual_seed(0);
  const int64_t n = state.range(0);
  DbarfModel model(DbarfOptions::Cpu());
  model.Train(false);
  model.pose_net->SetDepthRange(1.0, 8.0);
  torch::NoGradGuard no_grad;
  const torch::Tensor target = torch::rand({1, 3, kHeight, kWidth}), sources = torch::rand({n, 3, kHeight, kWidth});
  const torch::Tensor init = SourcePoses(n);
  for (auto _ : state) benchmark::DoNotOptimize(model.pose_net->forward(target, sources, Intrinsics(), init));
}
BENCHMARK(BM_PoseDepthForward)->Arg(4)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace nerfreg

BENCHMARK_MAIN();
