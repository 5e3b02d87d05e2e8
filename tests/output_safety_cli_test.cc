// Outputs are safe (issue: full disks, --force, races, signals): every writer family fails a full
// disk with one line and exit 2 and leaves nothing behind; --force replaces only what nerfreg
// wrote and never an input; two runs to one output cannot both succeed; SIGTERM / SIGINT leave the
// last checkpoint loadable. A full disk is stood in for by a file-size limit of 0 (`ulimit -f 0`:
// the kernel fails every write with EFBIG, as a full disk fails it with ENOSPC).
#include <gtest/gtest.h>

#include <filesystem>

#include "cli_test_util.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

namespace fs = std::filesystem;

// Names under `dir` (recursively) that look like a temporary or half-written output.
std::vector<std::string> Leftovers(const std::string& dir) {
  std::vector<std::string> found;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.find(".tmp.") != std::string::npos || name.find(".tmp-") != std::string::npos ||
        name.find(".old-") != std::string::npos || name.find(".nerfreg-probe") != std::string::npos) {
      found.push_back(e.path().string());
    }
  }
  return found;
}

CommandResult RunNerfregOnFullDisk(const std::string& args) {
  return RunShell("ulimit -f 0; exec " + std::string(NERFREG_BINARY) + " " + args);
}

// A tiny dataset and a block trained on it, shared by the tests below (a few seconds).
class OutputSafetyCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new ScopedTempDir();
    ASSERT_EQ(
        RunNerfreg("render --procedural 4 --views 12 --size 24 --supersample 1 --test-every 6 --quiet --out " + Data())
            .exit_code,
        0);
    const CommandResult r =
        RunNerfreg("nerf train " + Data() + " --out " + Block() + " --iters 10 --samples 4096 --quiet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Data() { return dir_->File("data"); }
  static std::string Block() { return dir_->File("b.ckpt"); }
  static ScopedTempDir* dir_;
};
ScopedTempDir* OutputSafetyCli::dir_ = nullptr;

TEST_F(OutputSafetyCli, FullDiskIsAnErrorForEveryWriterFamily) {
  ScopedTempDir dir;
  struct Case {
    std::string args, output;
  };
  const std::vector<Case> cases = {
      // A torch archive (NeRF checkpoint): LibTorch's writer used to abort (exit 134).
      {"nerf train " + Data() + " --out " + dir.File("n.ckpt") + " --iters 3 --samples 4096", "n.ckpt"},
      // A torch archive (registration grid).
      {"reg extract " + Block() + " --grid-resolution 8 --out " + dir.File("g.grid"), "g.grid"},
      // PNGs into an output folder (they used to be left truncated, exit 0).
      {"nerf render " + Block() + " --transforms " + Data() + "/transforms.json --out " + dir.File("renders"),
       "renders"},
      // A dataset folder of PNGs and JSON (errors name the file by its final path).
      {"render --procedural 2 --views 3 --size 16 --supersample 1 --out " + dir.File("rendered"), "rendered"},
      // JSON and PLY files.
      {"nerf eval " + Block() + " " + Data() + " --out " + dir.File("e.json"), "e.json"},
      {"nerf export " + Block() + " --points " + dir.File("p.ply"), "p.ply"},
  };
  for (const Case& c : cases) {
    const CommandResult r = RunNerfregOnFullDisk(c.args + " --quiet");
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    // "error: DIR/OUT: expected ..." or, inside an output folder, "error: DIR/OUT/FILE: expected ...".
    EXPECT_NE(r.output.find("error: " + dir.File(c.output)), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(": expected space to write (disk full?)"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir.File(c.output))) << c.args;
  }
  EXPECT_EQ(Leftovers(dir.path()), std::vector<std::string>{});
}

// A checkpoint write that fails (full disk at step 10 of a resumed run) keeps the earlier
// checkpoint whole: it still loads, and a later --resume goes on from it.
TEST_F(OutputSafetyCli, FailedCheckpointWriteKeepsTheLastCheckpoint) {
  ScopedTempDir dir;
  const std::string ckpt = dir.File("b.ckpt");
  CommandResult r =
      RunNerfreg("nerf train " + Data() + " --out " + ckpt + " --iters 10 --stop-after 5 --samples 4096 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(LoadNerfBlock(ckpt).step, 5);
  r = RunNerfregOnFullDisk("nerf train " + Data() + " --out " + ckpt + " --iters 10 --samples 4096 --resume --quiet");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("b.ckpt: expected space to write"), std::string::npos) << r.output;
  EXPECT_EQ(LoadNerfBlock(ckpt).step, 5);
  r = RunNerfreg("nerf train " + Data() + " --out " + ckpt + " --iters 10 --samples 4096 --resume --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(LoadNerfBlock(ckpt).step, 10);
  // Resuming the finished run trains nothing and keeps its test PSNR (it used to write 0).
  const double psnr = ReadJsonFile(ckpt + ".json")["psnr_test"].get<double>();
  EXPECT_GT(psnr, 5);
  r = RunNerfreg("nerf train " + Data() + " --out " + ckpt + " --iters 10 --samples 4096 --resume --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NEAR(ReadJsonFile(ckpt + ".json")["psnr_test"].get<double>(), psnr, 1e-6);
  EXPECT_EQ(Leftovers(dir.path()), std::vector<std::string>{});
}

TEST_F(OutputSafetyCli, ForceReplacesOnlyWhatNerfregWroteAndNeverAnInput) {
  ScopedTempDir dir;
  // A folder of the user's: --force must not delete it.
  const std::string mine = dir.File("mine");
  WriteFileAtomic(mine + "/notes.txt", "keep me");
  CommandResult r =
      RunNerfreg("render --procedural 2 --views 3 --size 16 --supersample 1 --quiet --force --out " + mine);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("mine: expected a folder written by nerfreg"), std::string::npos) << r.output;
  EXPECT_EQ(ReadFileToString(mine + "/notes.txt"), "keep me");
  // nerfreg's own output folder is replaced whole.
  const std::string out = dir.File("out");
  ASSERT_EQ(RunNerfreg("render --procedural 2 --views 3 --size 16 --supersample 1 --quiet --out " + out).exit_code, 0);
  ASSERT_TRUE(fs::exists(out + "/" + kOutputMarker));
  r = RunNerfreg("render --procedural 2 --views 4 --size 16 --supersample 1 --quiet --force --out " + out);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out + "/images/r_003.png"));
  // The dataset's own transforms.json, as a training output: refused even with --force.
  const std::string before = ReadFileToString(Data() + "/transforms.json");
  r = RunNerfreg("nerf train " + Data() + " --out " + Data() + "/transforms.json --iters 2 --force --quiet");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("transforms.json: expected an output that is not an input"), std::string::npos) << r.output;
  EXPECT_EQ(ReadFileToString(Data() + "/transforms.json"), before);
  // An output folder that holds the inputs.
  r = RunNerfreg("nerf render " + Block() + " --transforms " + Data() + "/transforms.json --force --quiet --out " +
                 Data());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(ReadFileToString(Data() + "/transforms.json"), before);
  EXPECT_EQ(Leftovers(dir.path()), std::vector<std::string>{});
}

TEST_F(OutputSafetyCli, UserMistakesAreNamedErrorsBeforeAnyWork) {
  ScopedTempDir dir;
  for (const char* iters : {"0", "-5"}) {
    const CommandResult r = RunNerfreg("nerf train " + Data() + " --out " + dir.File("x.ckpt") + " --iters " + iters);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("error: --iters: expected at least 1 iteration"), std::string::npos) << r.output;
  }
  CommandResult r = RunNerfreg("render --procedural 1 --out \"\"");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("error: --out: expected a path"), std::string::npos) << r.output;
  // An output whose folder is a file: found before training, not after.
  r = RunNerfreg("nerf train " + Data() + " --out " + Data() + "/transforms.json/b.ckpt --iters 100000");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("expected a path whose parent is a folder"), std::string::npos) << r.output;
}

// Two runs to one new output folder: one result, never a silently lost one. Whichever finishes
// second fails (at the start, or at the end if both started before either finished).
TEST_F(OutputSafetyCli, TwoConcurrentRunsToOneOutputCannotBothSucceed) {
  ScopedTempDir dir;
  const std::string run =
      std::string(NERFREG_BINARY) + " render --procedural 3 --views 6 --size 32 --quiet --out " + dir.File("out");
  const CommandResult r = RunShell(run + " >/dev/null 2>&1 & a=$!; " + run +
                                   " >/dev/null 2>&1 & b=$!; wait $a; x=$?; wait $b; echo codes $x $?");
  const size_t at = r.output.find("codes ");
  ASSERT_NE(at, std::string::npos) << r.output;
  const std::string codes = r.output.substr(at + 6, 3);
  EXPECT_TRUE(codes == "0 2" || codes == "2 0") << r.output;
  EXPECT_EQ(Leftovers(dir.path()), std::vector<std::string>{});
}

// SIGTERM and SIGINT: exit 143 / 130, no temporary file, and the last checkpoint loads.
TEST_F(OutputSafetyCli, TerminationSignalsLeaveTheLastCheckpointLoadable) {
  for (const char* signal : {"TERM", "INT"}) {
    ScopedTempDir dir;
    const std::string ckpt = dir.File("b.ckpt");
    const CommandResult r =
        RunShell("timeout --preserve-status -s " + std::string(signal) + " 6 " + NERFREG_BINARY + " nerf train " +
                 Data() + " --out " + ckpt + " --iters 100000 --samples 4096 --checkpoint-every 2 --quiet");
    EXPECT_EQ(r.exit_code, std::string(signal) == "TERM" ? 143 : 130) << r.output;
    ASSERT_TRUE(FileExists(ckpt)) << r.output;
    EXPECT_GT(LoadNerfBlock(ckpt).step, 0);
    EXPECT_EQ(Leftovers(dir.path()), std::vector<std::string>{});
  }
}

}  // namespace
}  // namespace nerfreg
