// Registration timings on 2 CPU threads, through the chain every job runs
// (registration/registration_chain.h): the DReg-NeRF network on a grid pair as `reg eval --pairs
// --methods dreg --refine none` and `reg register --refine none` run it (RunChain; Cpu()
// configuration, D = 64 and 32), one training step, and the chain's field stage as `reg register
// --refine field` runs it (RefineOnFields; two blocks of `nerf train`'s fast preset). Untrained
// weights and fields: the cost does not depend on them.
//   build/bench/nerfreg_reg_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <Eigen/Geometry>

#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/reg/dreg_loss.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg/test_grids.h"
#include "nerfreg/registration/registration_chain.h"

namespace nerfreg {
namespace {

struct Pair {
  RegGrid src, tgt;
  torch::Tensor target_from_source;
};

Pair MakePair(int resolution) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(1.3, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.15, -0.1, 0.1);
  return {MakeShapeGrid(resolution, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1),
          MakeShapeGrid(resolution, r, t, 2), RigidMatrix(r, t)};
}

void BM_DregRegisterCpu(benchmark::State& state) {
  torch::set_num_threads(2);
  torch::manual_seed(1);
  const Pair pair = MakePair(static_cast<int>(state.range(0)));
  DregNet net(DregModelOptions::Cpu());
  BlockRegistrationOptions o;
  o.method = RegistrationMethod::kDreg;
  o.refine = RegistrationRefinement::kNone;
  o.scale = ScaleMode::kFixed;
  RegistrationPair grids(pair.src, pair.tgt, nullptr, nullptr, o);
  int points = 0;
  for (auto _ : state) {
    const RegistrationResult reg = RunChain(grids, o.method, RegistrationCloud::kGridMask, o, &net);
    points = reg.source_points + reg.target_points;
  }
  state.counters["keypoints"] = points;
}
BENCHMARK(BM_DregRegisterCpu)->Arg(64)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();

// One training step: forward, DregLoss, backward, AdamW.
void BM_DregTrainStepCpu(benchmark::State& state) {
  torch::set_num_threads(2);
  torch::manual_seed(1);
  const Pair pair = MakePair(static_cast<int>(state.range(0)));
  DregNet net(DregModelOptions::Cpu());
  torch::optim::AdamW opt(net->parameters(), torch::optim::AdamWOptions(1e-4).weight_decay(1e-4));
  for (auto _ : state) {
    const DregOutput out = net->forward(pair.src, pair.tgt);
    const DregLossTerms loss = DregLoss(out, pair.src, pair.tgt, pair.target_from_source);
    opt.zero_grad();
    loss.total.backward();
    opt.step();
  }
}
BENCHMARK(BM_DregTrainStepCpu)->Arg(64)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();

// The chain's field stage (RefineOnFields: AlignFields on the blocks' density fields) between two
// fast-preset blocks, state.range(0) samples per block (the default is 6000): every LM iteration
// queries 7 densities per sample. Reports the time per iteration (a refinement takes 5-33 on real
// pairs).
void BM_FieldAlignment(benchmark::State& state) {
  torch::set_num_threads(2);
  const NerfTrainOptions t = NerfTrainOptions::Preset("fast");
  NerfBlock a = NerfBlock::Create(t.field, t.grid, t.march, 1), b = NerfBlock::Create(t.field, t.grid, t.march, 2);
  const int n = static_cast<int>(state.range(0)) / 2;
  Eigen::Matrix3Xd points = Eigen::Matrix3Xd::Random(3, n);
  points.colwise().normalize();  // a unit sphere's surface
  BlockRegistrationOptions o;
  o.scale = ScaleMode::kFixed;
  o.field.max_samples = static_cast<int>(state.range(0));
  o.field.iterations = 10;
  o.field.tolerance_deg = 0;
  o.grid.resolution = 32;
  o.grid.side = 32 * o.field.sample_spread;  // the pair's cell: the samples' spread
  NerfBlockInput source(a), target(b);
  RegistrationPair blocks(points, points, &source, &target, o);
  RegistrationResult start;
  start.target_from_source =
      Sim3d(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ())), Eigen::Vector3d::Zero());
  start.cloud = RegistrationCloud::kOccupied;
  int iterations = 0;
  double seconds = 0;
  for (auto _ : state) {
    RegistrationResult r = start;
    RefineOnFields(blocks, o, &r);
    iterations += r.field["iterations"].get<int>() + 1;  // + the first linearisation
    seconds += r.field["seconds"].get<double>();
  }
  state.counters["ms_per_iteration"] = 1e3 * seconds / std::max(iterations, 1);
}
BENCHMARK(BM_FieldAlignment)->Arg(6000)->Arg(2000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace nerfreg

BENCHMARK_MAIN();
