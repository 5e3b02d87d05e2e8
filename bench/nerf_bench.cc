// NeRF-block kernels, fused vs torch-ops reference, on 2 CPU threads:
//   build/bench/nerfreg_nerf_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include "nerfreg/nerf/field.h"
#include "nerfreg/nerf/hash_encoding.h"
#include "nerfreg/nerf/volume_rendering.h"

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
  state.counters["GB/s"] = benchmark::Counter(double(n) * state.iterations() * (8 * 16 * 2 + 32) * 4 / 1e9, benchmark::Counter::kIsRate);
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

}  // namespace
}  // namespace nerfreg

BENCHMARK_MAIN();
