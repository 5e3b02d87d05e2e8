// `--device` on every command that runs a network: parsed once, before any file is read or
// written; a device this build or machine lacks is one named error line and exit 2.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"

namespace nerfreg {
namespace {

// Each command with the least arguments CLI11 accepts; none of the paths exists, so a run that got
// past the device check would fail on them instead (with another message).
const std::vector<std::string>& Commands() {
  static const std::vector<std::string> commands = {
      "nerf train no_dataset --out no_dir/a.ckpt",
      "nerf render no.ckpt --transforms no.json --out no_dir/r",
      "nerf eval no.ckpt no_dataset",
      "nerf export no.ckpt --points no_dir/p.ply",
      "reg extract no.ckpt --out no_dir/g.grid",
      "reg train no_pairs.json --out no_dir/w.pt",
      "reg register no_a.ckpt no_b.ckpt --out no_dir/t.json",
      "reg eval --pairs no_pairs.json",
      "dbarf pretrain no_scene --out no_dir/w.pt",
      "dbarf finetune no_scene --out no_dir/w.pt",
      "dbarf render no_posed --transforms no.json --out no_dir/r",
      "dbarf eval no_dataset --out no_dir/e",
      "dbarf poses no_images --focal 100 --out no_dir/p",
      "dbarf eval-net no_dataset",
  };
  return commands;
}

void ExpectDeviceError(const std::string& command, const std::string& device, const std::string& expected) {
  const CommandResult r = RunNerfreg(command + " --device " + device);
  EXPECT_EQ(r.exit_code, 2) << command << "\n" << r.output;
  EXPECT_NE(r.output.find("error: --device: " + device + ": expected " + expected), std::string::npos)
      << command << "\n"
      << r.output;
  EXPECT_FALSE(std::filesystem::exists("no_dir")) << command;
}

TEST(DeviceCli, UnknownDeviceIsANamedErrorOnEveryCommand) {
  for (const auto& c : Commands()) ExpectDeviceError(c, "tpu", "cpu, cuda, cuda:N");
}

TEST(DeviceCli, MissingCudaDeviceIsANamedErrorOnEveryCommand) {
  // No machine has a thousand GPUs: refused with or without CUDA.
  for (const auto& c : Commands()) ExpectDeviceError(c, "cuda:999", "a CUDA device");
}

TEST(DeviceCli, CudaWithoutAGpuIsExit2) {
  if (std::filesystem::exists("/dev/nvidia0")) GTEST_SKIP() << "this machine has a GPU";
  ExpectDeviceError("nerf train no_dataset --out no_dir/a.ckpt", "cuda", "a CUDA device (none is available");
  ExpectDeviceError("reg train no_pairs.json --out no_dir/w.pt", "cuda", "a CUDA device (none is available");
}

TEST(DeviceCli, CpuAndAutoPassTheDeviceCheck) {
  // The run goes on to the next check (a missing input), which names the file, not --device.
  for (const std::string device : {"cpu", "auto"}) {
    const CommandResult r = RunNerfreg("nerf eval no.ckpt no_dataset --device " + device);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_EQ(r.output.find("--device"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("no.ckpt"), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace nerfreg
