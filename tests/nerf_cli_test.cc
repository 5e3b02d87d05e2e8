// Crash safety of `nerf train`: SIGKILL in the middle of a run leaves a loadable checkpoint (never
// a half-written one), and --resume continues from it to the end.
#include <gtest/gtest.h>

#include <filesystem>

#include "cli_test_util.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(NerfCli, SigkillMidRunThenResume) {
  ScopedTempDir dir;
  ASSERT_EQ(RunNerfreg("render --procedural 4 --views 30 --size 24 --supersample 1 --test-every 6 --quiet --out " +
                       dir.File("data"))
                .exit_code,
            0);
  const std::string train = "nerf train " + dir.File("data") + " --out " + dir.File("b.ckpt") +
                            " --iters 100000 --samples 4096 --checkpoint-every 5 --quiet";
  // Killed without warning after a few seconds, mid-run.
  const CommandResult killed = RunShell("timeout -s KILL 8 " + std::string(NERFREG_BINARY) + " " + train);
  EXPECT_EQ(killed.exit_code, 137) << killed.output;
  NerfBlock block = LoadNerfBlock(dir.File("b.ckpt"));
  EXPECT_GT(block.step, 0);
  EXPECT_LT(block.step, 100000);
  EXPECT_EQ(block.step % 5, 0);
  // Resume to a near end: it continues from the checkpoint's step, not from zero. (A kill during
  // a checkpoint write may leave a temporary file beside it; the resumed run's first write
  // removes it, checked below.)
  const int target = block.step + 10;
  const CommandResult resumed = RunNerfreg("nerf train " + dir.File("data") + " --out " + dir.File("b.ckpt") +
                                           " --iters " + std::to_string(target) + " --samples 4096 --resume --quiet");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_EQ(LoadNerfBlock(dir.File("b.ckpt")).step, target);
  const Json summary = ReadJsonFile(dir.File("b.ckpt.json"));
  EXPECT_EQ(summary["iters"].get<int>(), target);
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    const std::string name = e.path().filename().string();
    const size_t tmp = name.find(".tmp.");
    // On failure, what the sweep saw of the writer's PID (".NAME.tmp.PID.N").
    EXPECT_EQ(tmp, std::string::npos)
        << e.path() << "; the writer's process: "
        << RunShell("cat /proc/" + name.substr(tmp + 5, name.rfind('.') - tmp - 5) + "/stat").output;
  }
  // A new run over an existing checkpoint is refused without --force.
  const CommandResult again =
      RunNerfreg("nerf train " + dir.File("data") + " --out " + dir.File("b.ckpt") + " --iters 5 --quiet");
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.output.find("exists; pass --force"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
