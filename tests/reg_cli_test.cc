// End-to-end registration commands: reg make-data -> reg train (SIGKILL mid-run, --resume) ->
// reg eval --pairs with every method; the bad-input cases of the registration network.
#include <gtest/gtest.h>

#include <filesystem>

#include "cli_test_util.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(RegCli, MakeDataTrainKilledResumeAndEval) {
  ScopedTempDir dir;
  const CommandResult made = RunNerfreg("reg make-data --procedural 2 --mesh-pairs 1 --grid-resolution 32 --quiet --out " +
                                        dir.File("data"));
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const Json pairs = ReadJsonFile(dir.File("data/pairs.json"));
  ASSERT_EQ(pairs["pairs"].size(), 2u);
  // make-data resumes: a second run skips the finished objects.
  const CommandResult again = RunNerfreg("reg make-data --procedural 2 --mesh-pairs 1 --grid-resolution 32 --out " +
                                         dir.File("data"));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("\"objects_skipped\":2"), std::string::npos) << again.output;

  // Killed without warning mid-run: the weights and the training state still load.
  const std::string train = "reg train " + dir.File("data/pairs.json") + " --out " + dir.File("w.pt") +
                            " --iters 100000 --checkpoint-every 2 --val-every 0 --quiet";
  const CommandResult killed = RunShell("timeout -s KILL 15 " + std::string(NERFREG_BINARY) + " " + train);
  EXPECT_EQ(killed.exit_code, 137) << killed.output;
  DregModelOptions options;
  EXPECT_NO_THROW(LoadDregWeights(dir.File("w.pt"), &options));
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  }
  // The log says how far it got; --resume continues from the last checkpoint to a near end.
  int last_step = 0;
  {
    const CommandResult tail = RunShell("tail -n 1 " + dir.File("w.pt.log.jsonl"));
    last_step = Json::parse(tail.output)["step"].get<int>();
  }
  ASSERT_GT(last_step, 0);
  const int target = last_step + 3;
  const CommandResult resumed = RunNerfreg("reg train " + dir.File("data/pairs.json") + " --out " + dir.File("w.pt") +
                                           " --iters " + std::to_string(target) + " --val-every 0 --resume --quiet");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  const Json summary = ReadJsonFile(dir.File("w.pt.json"));
  EXPECT_EQ(summary["iterations"].get<int>(), target);
  // It did not start again from zero: no step 1 after the resume.
  const CommandResult steps = RunShell("grep -c '\"step\":1,' " + dir.File("w.pt.log.jsonl"));
  EXPECT_EQ(steps.output.substr(0, 1), "1") << steps.output;

  // Every method on the pairs, one table with a summary line per method.
  const CommandResult eval = RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --split all --methods dreg,ransac " +
                                        "--refine none,icp --weights " + dir.File("w.pt") + " --out " + dir.File("eval.json"));
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  const Json table = ReadJsonFile(dir.File("eval.json"));
  EXPECT_EQ(table["rows"].size(), 2u * 4u);
  EXPECT_TRUE(table["summary"].contains("ransac+icp"));
  EXPECT_TRUE(table["summary"].contains("dreg"));
  // FPFH + RANSAC + ICP agrees with these synthesised pairs' ground truth (a wrong or inverted one
  // is tens of degrees off; one point per 0.11-unit cell limits ICP to a few degrees: 3.1 measured).
  EXPECT_LT(table["summary"]["ransac+icp"]["median_rotation_deg"].get<double>(), 10.0);
}

TEST(RegCli, BadWeightsAreClearErrors) {
  ScopedTempDir dir;
  ASSERT_EQ(RunNerfreg("reg make-data --procedural 1 --mesh-pairs 1 --grid-resolution 32 --quiet --out " + dir.File("data")).exit_code, 0);
  RunShell("echo 'not weights' > " + dir.File("bad.pt"));
  const CommandResult r = RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --split all --methods dreg --weights " +
                                     dir.File("bad.pt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bad.pt"), std::string::npos) << r.output;
  const CommandResult missing = RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --split all --methods dreg --weights " +
                                           dir.File("none.pt"));
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("none.pt"), std::string::npos) << missing.output;
}

}  // namespace
}  // namespace nerfreg
