// Timings of the learned core on one device, for scripts/gpu_check.sh. Built with the learned
// core alone (no Embree / Open3D / Ceres / OpenCV), so its NeRF scene is analytic: a sphere whose
// colour varies with the normal, rendered exactly. Prints one JSON object (and writes it to --out).
//   build-gpu/bench/nerfreg_gpu_bench --device cuda --out results/gpu_bench.json
#include <torch/torch.h>
#include <torch/version.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "nerfreg/data/dataset.h"
#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/dbarf/test_scene.h"
#include "nerfreg/nerf/hash_encoding.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/nerf/test_sphere.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/reg/dreg_loss.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/test_grids.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/torch_device.h"

namespace nerfreg {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

void Sync(const torch::Device& device) {
  if (device.is_cuda()) torch::cuda::synchronize(device.index());
}

// Hash encoding forward + backward at the paper's sizes (16 levels x 2, 2^19 entries), n points.
Json HashEncodingTiming(const torch::Device& device, std::int64_t n, int iterations) {
  const HashEncodingOptions o;  // the paper's
  torch::manual_seed(1);
  const auto x = torch::rand({n, 3}).to(device);
  auto table = InitHashTable(o).to(device).requires_grad_(true);
  const auto w = torch::randn({n, o.OutputDim()}).to(device);
  double seconds = 0;
  for (int i = -2; i < iterations; ++i) {  // two warm-up rounds
    Sync(device);
    const auto t0 = Clock::now();
    table.mutable_grad() = torch::Tensor();
    (HashEncode(x, table, o) * w).sum().backward();
    Sync(device);
    if (i >= 0) seconds += Since(t0);
  }
  return {{"points", n},
          {"ms_per_forward_backward", 1e3 * seconds / iterations},
          {"points_per_second", double(n) * iterations / seconds}};
}

// Trains a block of the paper's preset on the sphere; returns the seconds to the first evaluation
// at or above `target_psnr` (or -1) and the steps per second.
Json NerfTiming(const torch::Device& device, const std::string& dir, int views, int size, int iterations,
                int eval_every, double target_psnr) {
  const Dataset d = SphereDataset(dir, views, size);
  NerfTrainOptions o = NerfTrainOptions::Preset("default");
  o.iterations = iterations;
  o.eval_every = eval_every;
  o.checkpoint_every = 0;
  o.max_eval_views = 4;
  o.device = device;
  const std::string ckpt = dir + "/block.ckpt";
  const NerfTrainResult r = TrainNerfBlock(d, o, ckpt, false);
  double seconds_to_target = -1;
  std::ifstream log(ckpt + ".log.jsonl");
  for (std::string line; std::getline(log, line);) {
    const Json j = Json::parse(line);
    if (seconds_to_target < 0 && j.contains("test_psnr") && j["test_psnr"].get<double>() >= target_psnr) {
      seconds_to_target = j["seconds"].get<double>();
    }
  }
  return {{"views", views},
          {"size", size},
          {"iterations", r.iterations},
          {"seconds", r.seconds},
          {"steps_per_second", r.iterations / r.seconds},
          {"psnr_test", r.psnr_test},
          {"target_psnr", target_psnr},
          {"seconds_to_target", seconds_to_target}};
}

// DReg-NeRF training steps (forward, loss, backward, AdamW) of the paper's network on a grid pair.
Json RegTiming(const torch::Device& device, int resolution, int steps) {
  torch::manual_seed(1);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(1.3, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.15, -0.1, 0.1);
  const RegGrid src = MakeShapeGrid(resolution, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1);
  const RegGrid tgt = MakeShapeGrid(resolution, r, t, 2);
  const torch::Tensor gt = RigidMatrix(r, t);
  DregNet net(DregModelOptions::Paper());
  net->to(device);
  torch::optim::AdamW opt(net->parameters(), torch::optim::AdamWOptions(1e-4).weight_decay(1e-4));
  double seconds = 0;
  for (int i = -2; i < steps; ++i) {
    Sync(device);
    const auto t0 = Clock::now();
    const DregOutput out = net->forward(src, tgt);
    const DregLossTerms loss = DregLoss(out, src, tgt, gt);
    opt.zero_grad();
    loss.total.backward();
    opt.step();
    Sync(device);
    if (i >= 0) seconds += Since(t0);
  }
  return {
      {"config", "paper"}, {"grid_resolution", resolution}, {"steps", steps}, {"steps_per_second", steps / seconds}};
}

// DBARF pretraining steps of the paper's networks on an analytic ridge scene (tests' scene).
Json DbarfTiming(const torch::Device& device, int steps) {
  using testing_scene::PlaneScene;
  torch::manual_seed(1);
  const PlaneScene ridge = PlaneScene::Ridge(2.0, 0.4, 240, 320);
  const int views = 4;  // SourcePoses() has 3 poses
  const torch::Tensor poses = torch::cat({torch::eye(4).unsqueeze(0), testing_scene::SourcePoses(views - 1)}, 0);
  DbarfScene scene;
  scene.name = "ridge";
  std::vector<torch::Tensor> images;
  for (int v = 0; v < views; ++v) {
    images.push_back(ridge.Render(poses[v]));
    scene.image_names.push_back("v" + std::to_string(v) + ".png");
    std::vector<int> n;
    for (int j = 0; j < views; ++j)
      if (j != v) n.push_back(j);
    scene.neighbours.push_back(n);
    scene.usable.push_back(true);
  }
  scene.images = torch::cat(images, 0);
  scene.intrinsics = ridge.intrinsics.unsqueeze(0).repeat({views, 1, 1});
  scene.cam_from_world = poses;
  scene.near = 1.0;
  scene.far = 8.0;
  DbarfModel model(DbarfOptions::Paper());
  model.To(device);
  DbarfTrainOptions o = DbarfTrainOptions::Pretrain();
  o.stage_steps = 2;  // every stage is timed
  DbarfTrainer trainer(&model, {DbarfSceneTo(scene, device)}, o);
  for (int i = 0; i < 2; ++i) trainer.Step();
  Sync(device);
  const auto t0 = Clock::now();
  for (int i = 0; i < steps; ++i) trainer.Step();
  Sync(device);
  return {{"config", "paper"},
          {"image_size", "320x240"},
          {"views", views},
          {"steps", steps},
          {"steps_per_second", steps / Since(t0)}};
}

}  // namespace
}  // namespace nerfreg

int main(int argc, char** argv) {
  using namespace nerfreg;
  std::string device_name = "auto", out, work = "gpu_bench_work", only;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "error: %s: expected a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--device")
      device_name = next();
    else if (a == "--out")
      out = next();
    else if (a == "--work")
      work = next();
    else if (a == "--only")
      only = next();
    else if (a == "--quick")
      quick = true;
    else {
      std::fprintf(stderr,
                   "usage: nerfreg_gpu_bench [--device D] [--out FILE] [--work DIR] [--only "
                   "hash,nerf100,nerf800,reg,dbarf] [--quick]\n");
      return 2;
    }
  }
  try {
    const torch::Device device = ParseDevice(device_name);
    Json j = {{"device", device.str()}, {"torch", TORCH_VERSION}};
    // --only takes a comma-separated list of hash, nerf100, nerf800 (nerf: both), reg, dbarf.
    const auto run = [&](const std::string& name) {
      if (only.empty()) return true;
      const std::string list = "," + only + ",";
      return list.find("," + name + ",") != std::string::npos ||
             (name.rfind("nerf", 0) == 0 && list.find(",nerf,") != std::string::npos);
    };
    if (run("hash")) {
      j["hash_encoding"] = HashEncodingTiming(device, quick ? 1 << 14 : 1 << 18, quick ? 2 : 20);
      std::fprintf(stderr, "hash encoding: %s\n", j["hash_encoding"].dump().c_str());
    }
    // The targets: 100x100 to 28 dB, and 800x800 with 100 views to 30 dB.
    if (run("nerf100")) {
      j["nerf_100"] = NerfTiming(device, work + "/sphere_100", quick ? 20 : 100, quick ? 32 : 100, quick ? 20 : 3000,
                                 quick ? 10 : 100, 28.0);
      std::fprintf(stderr, "nerf 100x100: %s\n", j["nerf_100"].dump().c_str());
    }
    if (run("nerf800") && !quick) {
      j["nerf_800"] = NerfTiming(device, work + "/sphere_800", 100, 800, 2000, 250, 30.0);
      std::fprintf(stderr, "nerf 800x800: %s\n", j["nerf_800"].dump().c_str());
    }
    if (run("reg")) {
      j["reg_train"] = RegTiming(device, quick ? 32 : 64, quick ? 2 : 20);
      std::fprintf(stderr, "reg train: %s\n", j["reg_train"].dump().c_str());
    }
    if (run("dbarf")) {
      j["dbarf_pretrain"] = DbarfTiming(device, quick ? 2 : 20);
      std::fprintf(stderr, "dbarf pretrain: %s\n", j["dbarf_pretrain"].dump().c_str());
    }
    std::printf("%s\n", j.dump(2).c_str());
    if (!out.empty()) WriteJsonFile(out, j);
  } catch (const InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return 0;
}
