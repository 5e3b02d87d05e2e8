// `--device` on every command that runs a network: parsed once, before any file is read or
// written; a device this build or machine lacks is one named error line and exit 2.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

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

// scripts/cli_device_check.sh, which the GPU check runs with --device cuda, here on the CPU at toy
// sizes: every command it names runs, the block trained in two halves (--resume) beats an untrained
// render, its evaluations on the training device and the CPU agree, and DBARF pretrains (resumed)
// and finetunes on the block's own images and cameras.
TEST(DeviceCli, DeviceCheckScriptRunsTheCommandsUsersRun) {
  ScopedTempDir dir;
  ASSERT_EQ(
      RunNerfreg("render --procedural 3 --views 12 --size 40 --test-every 6 --quiet --out " + dir.File("d")).exit_code,
      0);
  // No PAIRS_JSON, as on a lease without DReg data: reg train runs on the block's grid paired with
  // itself. WORK is relative, as gpu_check.sh's is (the first lease to run this, 2026-11-27, found
  // the grid's path in the pairs file read relative to that file).
  const CommandResult r =
      RunShell("cd " + dir.path() +
               " && CLI_CHECK_ITERS=120 CLI_CHECK_SAMPLES=16384 CLI_CHECK_CONFIG=cpu CLI_CHECK_DBARF_CONFIG=cpu "
               "CLI_CHECK_DBARF_STEPS=8 bash " +
               std::string(NERFREG_SOURCE_DIR) + "/scripts/cli_device_check.sh " + std::string(NERFREG_BINARY) +
               " d w cpu check.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json check = ReadJsonFile(dir.File("check.json"));
  std::vector<std::string> names;
  for (const auto& step : check["steps"]) {
    names.push_back(step["name"].get<std::string>());
    EXPECT_EQ(step["exit_code"].get<int>(), 0) << step.dump();
  }
  EXPECT_EQ(names, (std::vector<std::string>{"nerf_train_half", "nerf_train_resume", "nerf_eval", "nerf_eval_cpu",
                                             "nerf_render", "nerf_export", "reg_extract", "dbarf_pretrain_half",
                                             "dbarf_pretrain_resume", "dbarf_finetune", "reg_train"}));
  EXPECT_TRUE(check["psnr_agree"].get<bool>());
  // 120 steps of the fast preset on a 40-pixel object: far above the white-on-grey of an untrained block.
  EXPECT_GT(check["psnr_device"].get<double>(), 15.0) << check.dump();
  EXPECT_TRUE(std::filesystem::exists(dir.File("w/block.grid")));
  EXPECT_TRUE(std::filesystem::exists(dir.File("w/dreg.pt")));
  // DBARF: the resumed pretraining went on from its checkpoint to the total, its renderer trained
  // (a training PSNR exists only where the NeRF stages ran), and the result was finetuned.
  const Json& resumed = check["steps"][8]["printed"];
  EXPECT_EQ(resumed["steps"].get<int>(), 8) << resumed.dump();
  EXPECT_GT(resumed["psnr_train_last"].get<double>(), 0.0) << resumed.dump();
  EXPECT_TRUE(std::filesystem::exists(dir.File("w/dbarf_finetuned.pt")));
  EXPECT_TRUE(std::filesystem::exists(dir.File("w/views")));
}

// A failing command fails the script and is named in its JSON.
TEST(DeviceCli, DeviceCheckScriptFailsWhenACommandFails) {
  ScopedTempDir dir;
  ASSERT_EQ(
      RunNerfreg("render --procedural 3 --views 12 --size 40 --test-every 6 --quiet --out " + dir.File("d")).exit_code,
      0);
  const CommandResult r = RunShell("CLI_CHECK_ITERS=4 bash " + std::string(NERFREG_SOURCE_DIR) +
                                   "/scripts/cli_device_check.sh " + std::string(NERFREG_BINARY) + " " + dir.File("d") +
                                   " " + dir.File("w") + " tpu " + dir.File("check.json"));
  EXPECT_NE(r.exit_code, 0) << r.output;
  const Json check = ReadJsonFile(dir.File("check.json"));
  EXPECT_FALSE(check["all_exit_zero"].get<bool>());
  EXPECT_EQ(check["steps"][0]["exit_code"].get<int>(), 2);
}

// scripts/dbarf_device_train.sh, which the GPU check runs to train DBARF's paper configuration on a
// lease, here on the CPU at toy sizes: a run to its step total, a second call that resumes it and
// scores the pose network on the validation list, and a third stopped by its time limit that
// leaves a checkpoint to resume from.
TEST(DeviceCli, DbarfDeviceTrainScriptResumesAndStopsAtItsTimeLimit) {
  ScopedTempDir dir;
  std::string list;
  for (const std::string seed : {"1001", "1002"}) {
    ASSERT_EQ(RunNerfreg("render --procedural " + seed +
                         " --trajectory forward --views 6 --size 64x48 --test-every 8 "
                         "--quiet --out " +
                         dir.File("s" + seed))
                  .exit_code,
              0);
    list += dir.File("s" + seed + "/transforms.json") + "\n";
  }
  WriteFileAtomic(dir.File("data/train.txt"), list);
  WriteFileAtomic(dir.File("data/val.txt"), dir.File("s1002/transforms.json") + "\n");
  const auto run = [&](const std::string& env) {
    const CommandResult r =
        RunShell("DBARF_TRAIN_CONFIG=cpu DBARF_TRAIN_STAGE=1 " + env + " bash " + std::string(NERFREG_SOURCE_DIR) +
                 "/scripts/dbarf_device_train.sh " + std::string(NERFREG_BINARY) + " " + dir.File("data") + " " +
                 dir.File("w") + " cpu " + dir.File("train.json"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return ReadJsonFile(dir.File("train.json"));
  };
  const Json first = run("DBARF_TRAIN_STEPS=4 DBARF_TRAIN_CHECKPOINT=2");
  EXPECT_FALSE(first["resumed"].get<bool>()) << first.dump();
  EXPECT_EQ(first["step_reached"].get<int>(), 4) << first.dump();
  const Json second = run("DBARF_TRAIN_STEPS=8 DBARF_TRAIN_CHECKPOINT=2 DBARF_TRAIN_WINDOW=4");
  EXPECT_TRUE(second["resumed"].get<bool>()) << second.dump();
  EXPECT_EQ(second["step_before"].get<int>(), 4) << second.dump();
  EXPECT_EQ(second["step_reached"].get<int>(), 8) << second.dump();
  // The log by windows of 4 steps and stage: every logged step counted once, and the pose stages'
  // rows carry the depth's disparity (the scenes have ground truth), which shows a collapse.
  int logged = 0;
  bool pose_disparity = false;
  for (const auto& w : second["log_windows"]) {
    logged += w["steps"].get<int>();
    EXPECT_EQ(w["to_step"].get<int>() - w["from_step"].get<int>(), 4) << w.dump();
    if (w["stage"] == "pose") pose_disparity = w.contains("disparity");
  }
  EXPECT_EQ(logged, 8) << second.dump();
  EXPECT_TRUE(pose_disparity) << second.dump();
  // The pose network scored on the validation list, against the identity it starts from.
  EXPECT_EQ(second["eval_net"]["exit_code"].get<int>(), 0) << second.dump();
  EXPECT_GT(second["eval_net"]["start_rotation_deg"].get<double>(), 0.0) << second.dump();
  EXPECT_TRUE(second["eval_net"].contains("rotation_deg")) << second.dump();
  // A schedule far longer than the limit: stopped, with its checkpoint, and reported so.
  const Json third = run("DBARF_TRAIN_STEPS=100000 DBARF_TRAIN_CHECKPOINT=1 DBARF_TRAIN_SECONDS=15");
  EXPECT_EQ(third["step_before"].get<int>(), 8) << third.dump();
  EXPECT_TRUE(third["stopped_by_time_limit"].get<bool>()) << third.dump();
  EXPECT_TRUE(third["checkpoint"].get<bool>()) << third.dump();
  EXPECT_GT(third["step_reached"].get<int>(), 8) << third.dump();
  EXPECT_TRUE(std::filesystem::exists(dir.File("w/dbarf.pt")));
}

// Its work folder is replaced only if the script wrote it: a folder of someone else's is left as it is.
TEST(DeviceCli, DeviceCheckScriptLeavesAFolderItDidNotWrite) {
  ScopedTempDir dir;
  std::filesystem::create_directories(dir.File("mine"));
  WriteJsonFile(dir.File("mine/keep.json"), Json::object());
  ASSERT_EQ(
      RunNerfreg("render --procedural 3 --views 12 --size 40 --test-every 6 --quiet --out " + dir.File("d")).exit_code,
      0);
  const CommandResult r = RunShell("bash " + std::string(NERFREG_SOURCE_DIR) + "/scripts/cli_device_check.sh " +
                                   std::string(NERFREG_BINARY) + " " + dir.File("d") + " " + dir.File("mine") +
                                   " cpu " + dir.File("check.json"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("mine: expected an empty folder or one this script wrote"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir.File("mine/keep.json")));
  EXPECT_FALSE(std::filesystem::exists(dir.File("check.json")));
}

}  // namespace
}  // namespace nerfreg
