// Training on each device (cpu, cuda) from the same seed, on an analytic scene made in-process (the
// learned core has no render layer): the loss falls, the run starts from the CPU's batch, and the
// checkpoint a device writes holds CPU tensors and loads, evaluates and resumes on the CPU.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>

#include "nerfreg/nerf/test_sphere.h"
#include "nerfreg/nerf/test_train_options.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"
#include "nerfreg/util/torch_device.h"

namespace nerfreg {
namespace {

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
