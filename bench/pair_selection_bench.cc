// Pair selection's cost as the image count grows (issue 44: 200-500 photos must not need N^2/2
// matches). Synthetic descriptor sets shaped like a capture: 60 000 scene points with random SIFT-like
// descriptors (sparse, non-negative, 0..255); image i sees a window of 2 000 points that slides along
// the scene as i grows (a sweep), each row perturbed by noise. Retrieval and its vocabulary are
// built from these sets per run, as SelectPairs does for real images.
//   build/bench/nerfreg_pair_selection_bench --benchmark_counters_tabular=true
// Measured (2-core machine, nothing else running; wall time, 25 neighbours), with the
// vocabulary's products by the BLAS (2026-11-29): 100 images 0.44 s (1 552 pairs of 4 950), 200
// 0.56 s (2 980 of 19 900), 300 0.56 s (4 242 of 44 850), 500 0.90 s (6 405 of 124 750); with
// Eigen's SSE2 products (the binary before, run minutes earlier) 100 and 200 took 3.74 and 5.35 s.
#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include <random>

#include "nerfreg/viewgraph/pair_selection.h"

namespace nerfreg {
namespace {

std::vector<SiftDescriptors> SweepDescriptors(int n, int per_image) {
  constexpr int kPoints = 60000;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> value(0, 255), coin(0, 2), noise(-12, 12);
  SiftDescriptors points(kPoints, 128);
  for (int p = 0; p < kPoints; ++p)
    for (int c = 0; c < 128; ++c) points(p, c) = coin(rng) == 0 ? value(rng) : 0;
  std::vector<SiftDescriptors> out(n);
  for (int i = 0; i < n; ++i) {
    const int start = static_cast<int>(static_cast<int64_t>(i) * (kPoints - per_image) / std::max(1, n - 1));
    out[i].resize(per_image, 128);
    for (int r = 0; r < per_image; ++r)
      for (int c = 0; c < 128; ++c)
        out[i](r, c) = static_cast<uint8_t>(std::clamp(points(start + r, c) + noise(rng), 0, 255));
  }
  return out;
}

void BM_SelectPairsRetrieval(benchmark::State& state) {
  cv::setNumThreads(2);
  const int n = static_cast<int>(state.range(0));
  const std::vector<SiftDescriptors> d = SweepDescriptors(n, 2000);
  std::vector<std::string> names;
  for (int i = 0; i < n; ++i) names.push_back("img" + std::to_string(i) + "_x.jpg");  // not numbered frames
  PairSelectionOptions o;
  o.strategy = PairStrategy::kRetrieval;
  size_t pairs = 0;
  for (auto _ : state) pairs = SelectPairs(d, names, o).size();
  state.counters["images"] = n;
  state.counters["pairs"] = static_cast<double>(pairs);
  state.counters["all_pairs"] = n * (n - 1) / 2.0;
}
BENCHMARK(BM_SelectPairsRetrieval)->Arg(100)->Arg(200)->Arg(300)->Arg(500)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace nerfreg

BENCHMARK_MAIN();
