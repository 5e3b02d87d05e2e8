// Training on each device (cpu, cuda) from the same seed, on an analytic scene made in-process (the
// learned core has no render layer): the loss falls, the run starts from the CPU's batch, and the
// checkpoint a device writes holds CPU tensors and loads, evaluates and resumes on the CPU.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>

#include "nerfreg/nerf/test_train_options.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"
#include "nerfreg/util/torch_device.h"

namespace nerfreg {
namespace {

// A sphere of radius 0.6 at the origin, its colour varying with the normal, seen from `views`
// cameras at distance 3 (every 10th a test view); size x size RGBA PNGs, alpha 0 off the sphere.
// (bench/gpu_bench.cc's scene, small.)
Dataset SphereDataset(const std::string& dir, int views, int size) {
  std::filesystem::create_directories(dir);
  Dataset d;
  d.root = dir;
  d.aabb_min = Eigen::Vector3d::Constant(-0.7);
  d.aabb_max = Eigen::Vector3d::Constant(0.7);
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < views; ++i) {
    const double z = -0.8 + 1.6 * (i + 0.5) / views, r = std::sqrt(1 - z * z);
    const Eigen::Vector3d centre = 3.0 * Eigen::Vector3d(r * std::cos(golden * i), r * std::sin(golden * i), z);
    // OpenCV axes: z looks at the origin, x right, y down.
    const Eigen::Vector3d fwd = -centre.normalized();
    const Eigen::Vector3d right = fwd.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d down = fwd.cross(right);
    Eigen::Matrix3d world_from_cam;
    world_from_cam << right, down, fwd;
    Frame f;
    f.name = f.file_path = "r_" + std::to_string(i) + ".png";
    f.camera = Camera::FromFovX(size, size, 0.6);
    f.cam_from_world = Rigid3d(Eigen::Matrix3d(world_from_cam.transpose()), -world_from_cam.transpose() * centre);
    f.split = i % 10 == 5 ? "test" : "train";
    torch::Tensor o, dir_t;
    CameraRays(f.camera, f.cam_from_world, &o, &dir_t);  // [P, 3] each
    const auto b = (o * dir_t).sum(1), c = (o * o).sum(1) - 0.36;
    const auto disc = b * b - c;
    const auto hit = disc > 0;
    const auto t = -b - disc.clamp_min(0).sqrt();
    const auto normal = (o + dir_t * t.unsqueeze(1)) / 0.6;
    const auto rgb = (0.5 + 0.35 * normal + 0.1 * torch::sin(6 * normal.roll(1, 1))).clamp(0, 1);
    const auto rgba = torch::cat({rgb * hit.unsqueeze(1), hit.unsqueeze(1).to(torch::kFloat)}, 1).contiguous();
    Image im(size, size, 4);
    std::memcpy(im.data.data(), rgba.data_ptr<float>(), im.data.size() * sizeof(float));
    WriteImage(d.ImagePath(f), im);
    d.frames.push_back(f);
  }
  return d;
}

class NerfTrainDevice : public ::testing::TestWithParam<std::string> {
 protected:
  torch::Device Device() const {
    return GetParam() == "cuda" ? torch::Device(torch::kCUDA, 0) : torch::Device(torch::kCPU);
  }
  void SetUp() override {
    if (GetParam() == "cuda" && !CudaAvailable()) GTEST_SKIP() << "no CUDA device";
  }
};

INSTANTIATE_TEST_SUITE_P(Devices, NerfTrainDevice, ::testing::Values("cpu", "cuda"),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST_P(NerfTrainDevice, LossFallsAndTheCheckpointLoadsOnTheCpu) {
  constexpr int kSteps = 100;
  ScopedTempDir dir;
  const Dataset d = SphereDataset(dir.File("data"), 20, 32);
  NerfTrainOptions o = TinyNerfTrainOptions(kSteps);
  o.seed = 3;
  o.device = Device();
  const std::string ckpt = dir.File("b.ckpt");

  // Step 1 alone (checkpointed), then the rest resumed on the same device: the first and the
  // last step's batch loss.
  o.stop_after = 1;
  const NerfTrainResult first = TrainNerfBlock(d, o, ckpt, false);
  ASSERT_EQ(first.iterations, 1);
  o.stop_after = 0;
  const NerfTrainResult last = TrainNerfBlock(d, o, ckpt, true);
  ASSERT_EQ(last.iterations, kSteps);
  EXPECT_GT(first.final_loss, 0.0);
  EXPECT_LT(last.final_loss, 0.5 * first.final_loss) << "first " << first.final_loss;

  if (!o.device.is_cpu()) {
    // The same first step on the CPU: the batch, the marching offsets and the background colours
    // are drawn on the CPU whatever the device, and the field starts from the same weights, so the
    // loss differs by float rounding only (a cell at the occupancy threshold may flip).
    NerfTrainOptions cpu = o;
    cpu.device = torch::kCPU;
    cpu.stop_after = 1;
    const double cpu_loss = TrainNerfBlock(d, cpu, dir.File("cpu.ckpt"), false).final_loss;
    EXPECT_NEAR(first.final_loss, cpu_loss, 5e-3 * cpu_loss);
  }

  // The archive read without a device keeps each tensor's device: the checkpoint holds CPU ones.
  {
    torch::serialize::InputArchive ar;
    ar.load_from(ckpt);
    torch::Tensor density, occupied, table;
    ar.read("grid_density", density);
    ar.read("grid_occupied", occupied);
    torch::serialize::InputArchive field;
    ar.read("field", field);
    field.read("table", table);
    EXPECT_TRUE(density.is_cpu());
    EXPECT_TRUE(occupied.is_cpu());
    EXPECT_TRUE(table.is_cpu());
  }

  // Loaded on the CPU, the block renders the held-out views as the training device did.
  NerfBlock block = LoadNerfBlock(ckpt);
  EXPECT_TRUE(block.Device().is_cpu());
  EXPECT_TRUE(block.grid->device().is_cpu());
  EXPECT_EQ(block.step, kSteps);
  const double psnr = EvaluateNerfBlock(block, d).psnr;
  EXPECT_NEAR(psnr, last.psnr_test, 0.05);
  EXPECT_GT(psnr, 12.0);

  // And training goes on from it on the CPU.
  NerfTrainOptions more = o;
  more.device = torch::kCPU;
  more.iterations = kSteps + 5;
  const NerfTrainResult resumed = TrainNerfBlock(d, more, ckpt, true);
  EXPECT_EQ(resumed.iterations, kSteps + 5);
  EXPECT_TRUE(std::isfinite(resumed.final_loss));
}

}  // namespace
}  // namespace nerfreg
