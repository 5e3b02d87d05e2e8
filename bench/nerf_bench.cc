// NeRF-block kernels, fused vs torch-ops reference, on 2 CPU threads:
//   build/bench/nerfreg_nerf_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <stdlib.h>
#include <torch/torch.h>

#include "nerfreg/nerf/field.h"
#include "nerfreg/nerf/hash_encoding.h"
#include "nerfreg/nerf/sparse_adam.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/nerf/volume_rendering.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {
namespace {

HashEncodingOptions PaperEncoding(int log2) {
  HashEncodingOptions o;
  o.log2_table_size = log2;
  return o;
}

template <bool kFused>
void BM_HashEncodeForwardBackward(benchmark::State& state) {
  torch::set_num_threads(2);
  const auto o = PaperEncoding(17);
  const std::int64_t n = state.range(0);
  auto table = InitHashTable(o).requires_grad_(true);
  const auto x = torch::rand({n, 3});
  for (auto _ : state) {
    const auto y = kFused ? HashEncode(x, table, o) : HashEncodeReference(x, table, o);
    y.sum().backward();
    table.mutable_grad() = torch::Tensor();
  }
  state.counters["points/s"] = benchmark::Counter(double(n) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK_TEMPLATE(BM_HashEncodeForwardBackward, true)->Arg(1 << 16)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_HashEncodeForwardBackward, false)->Arg(1 << 16)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_HashEncodeForward(benchmark::State& state) {
  torch::set_num_threads(2);
  const auto o = PaperEncoding(17);
  const std::int64_t n = state.range(0);
  const auto table = InitHashTable(o);
  const auto x = torch::rand({n, 3});
  torch::NoGradGuard g;
  for (auto _ : state) benchmark::DoNotOptimize(HashEncode(x, table, o));
  state.counters["points/s"] = benchmark::Counter(double(n) * state.iterations(), benchmark::Counter::kIsRate);
  // Bytes touched: 8 corners x L levels x F floats read + the output written.
  state.counters["GB/s"] =
      benchmark::Counter(double(n) * state.iterations() * (8 * 16 * 2 + 32) * 4 / 1e9, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_HashEncodeForward)->Arg(1 << 16)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_FieldForwardBackward(benchmark::State& state) {
  torch::set_num_threads(2);
  FieldOptions fo;
  fo.encoding = PaperEncoding(17);
  NerfField field(fo);
  const std::int64_t n = state.range(0);
  const auto x = torch::rand({n, 3}) * 2 - 1, d = torch::nn::functional::normalize(torch::randn({n, 3}));
  for (auto _ : state) {
    auto [s, c] = field->Forward(x, d);
    (s.sum() + c.sum()).backward();
    field->zero_grad();
  }
  state.counters["samples/s"] = benchmark::Counter(double(n) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FieldForwardBackward)->Arg(1 << 16)->Unit(benchmark::kMillisecond)->UseRealTime();

template <bool kFused>
void BM_Composite(benchmark::State& state) {
  torch::set_num_threads(2);
  const std::int64_t rays = 1024, per = 64, S = rays * per;
  const auto offsets = torch::arange(0, S + 1, per, torch::kInt64);
  const auto ts = torch::rand({S}), te = ts + 0.01;
  auto sig = torch::rand({S}).requires_grad_(true);
  auto rgb = torch::rand({S, 3}).requires_grad_(true);
  for (auto _ : state) {
    const auto r = kFused ? Composite(sig, rgb, ts, te, offsets) : CompositeReference(sig, rgb, ts, te, offsets);
    (r.rgb.sum() + r.opacity.sum()).backward();
  }
  state.counters["samples/s"] = benchmark::Counter(double(S) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK_TEMPLATE(BM_Composite, true)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_Composite, false)->Unit(benchmark::kMillisecond)->UseRealTime();

// The encoding on ray-ordered points as training sees them (64 consecutive samples along each of
// 1024 random rays through the box) rather than uniformly random ones: neighbouring samples share
// table cache lines. Arg: log2 table size.
template <bool kFused>
void BM_HashEncodeRaysForwardBackward(benchmark::State& state) {
  torch::set_num_threads(2);
  const auto o = PaperEncoding(static_cast<int>(state.range(0)));
  auto table = InitHashTable(o).requires_grad_(true);
  const std::int64_t rays = 1024, per = 64;
  const auto start = torch::rand({rays, 1, 3}),
             dir = torch::nn::functional::normalize(torch::randn({rays, 1, 3}),
                                                    torch::nn::functional::NormalizeFuncOptions().dim(2));
  const auto t = torch::arange(per, torch::kFloat32).view({1, per, 1}) * (1.0f / 256);
  const auto x = (start + dir * t).clamp(0, 1).reshape({-1, 3}).contiguous();
  for (auto _ : state) {
    const auto y = kFused ? HashEncode(x, table, o) : HashEncodeReference(x, table, o);
    y.sum().backward();
    table.mutable_grad() = torch::Tensor();
  }
  state.counters["points/s"] = benchmark::Counter(double(x.size(0)) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK_TEMPLATE(BM_HashEncodeRaysForwardBackward, true)
    ->Arg(17)
    ->Arg(19)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_TEMPLATE(BM_HashEncodeRaysForwardBackward, false)->Arg(17)->Unit(benchmark::kMillisecond)->UseRealTime();

// One torch Adam step over the whole hash table (the trainer's optimizer; instant-NGP's tcnn Adam
// skips table entries whose gradient is zero). Arg: log2 table size.
void BM_AdamTableStep(benchmark::State& state) {
  torch::set_num_threads(2);
  const auto o = PaperEncoding(static_cast<int>(state.range(0)));
  auto table = InitHashTable(o).requires_grad_(true);
  table.mutable_grad() = torch::randn_like(table);
  torch::optim::Adam adam({table}, torch::optim::AdamOptions(1e-2).eps(1e-15));
  for (auto _ : state) adam.step();
  state.counters["params/s"] =
      benchmark::Counter(double(table.numel()) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_AdamTableStep)->Arg(17)->Arg(19)->Unit(benchmark::kMillisecond)->UseRealTime();

// SparseAdam (NerfTrainOptions::sparse_table_adam, off in both presets) on a realistic gradient:
// the encoding's backward of 64 samples along each of 1024 rays, which touches a fraction of the
// fine levels' entries.
void BM_SparseAdamTableStep(benchmark::State& state) {
  torch::set_num_threads(2);
  const auto o = PaperEncoding(static_cast<int>(state.range(0)));
  auto table = InitHashTable(o).requires_grad_(true);
  const auto start = torch::rand({1024, 1, 3}),
             dir = torch::nn::functional::normalize(torch::randn({1024, 1, 3}),
                                                    torch::nn::functional::NormalizeFuncOptions().dim(2));
  const auto x = (start + dir * torch::arange(64, torch::kFloat32).view({1, 64, 1}) / 256).clamp(0, 1).reshape({-1, 3});
  HashEncode(x.contiguous(), table, o).sum().backward();
  SparseAdam adam(table, SparseAdamOptions{});
  for (auto _ : state) adam.Step(1e-2);
  state.counters["params/s"] =
      benchmark::Counter(double(table.numel()) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["touched"] = (table.grad() != 0).to(torch::kFloat32).mean().item<double>();
}
BENCHMARK(BM_SparseAdamTableStep)->Arg(17)->Arg(19)->Unit(benchmark::kMillisecond)->UseRealTime();

// A scratch folder for this process, /tmp/nerfreg_nerf_bench.XXXXXX (left behind; small).
const std::string& ScratchDir() {
  static const std::string dir = [] {
    char tmpl[] = "/tmp/nerfreg_nerf_bench.XXXXXX";
    return std::string(mkdtemp(tmpl));
  }();
  return dir;
}

// A small orbit dataset (procedural object, 64x64, 24 views), rendered once.
const Dataset& BenchDataset() {
  static const Dataset d = [] {
    RenderDatasetOptions r;
    r.views = 24;
    r.width = 64;
    r.test_every = 8;
    r.render.supersample = 1;
    RenderDataset(ProceduralObject(2), r, ScratchDir() + "/data");
    return ReadTransformsJson(ScratchDir() + "/data/transforms.json");
  }();
  return d;
}

// End-to-end training iterations/s with the fast preset (sampling, marching, field, compositing,
// backward, Adam, grid updates; no evaluation). Args: {fused kernels (1) or references (0),
// log2 samples per batch}.
void BM_TrainIterations(benchmark::State& state) {
  torch::set_num_threads(2);
  InitLogging(LogOptions{/*quiet=*/true, false, false});  // no progress bar
  const Dataset& d = BenchDataset();
  const int iters = state.range(0) ? 48 : 4;
  double seconds = 0;
  for (auto _ : state) {
    NerfTrainOptions o = NerfTrainOptions::Preset("fast");
    o.iterations = 1000;
    o.stop_after = iters;
    o.target_samples = std::int64_t(1) << state.range(1);
    o.eval_every = 0;
    o.checkpoint_every = 0;
    o.field.reference_kernels = state.range(0) == 0;
    seconds += TrainNerfBlock(d, o, ScratchDir() + "/b.ckpt", false).seconds;
  }
  state.counters["it/s"] = benchmark::Counter(double(iters) * state.iterations() / seconds);
}
BENCHMARK(BM_TrainIterations)
    ->Args({1, 16})
    ->Args({1, 14})
    ->Args({0, 14})
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace
}  // namespace nerfreg

BENCHMARK_MAIN();
