// Data-parallel `reg train --nproc` end to end (c10d Gloo on the CPU): two processes compute the
// steps one process computes with the same global batch; a killed rank ends the job at once with
// a named error, and --resume continues it.
#include <gtest/gtest.h>

#include <regex>
#include <string>

#include "cli_test_util.h"
#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// The largest absolute difference over every parameter of two weights files.
double MaxWeightDifference(const std::string& a, const std::string& b) {
  DregModelOptions oa, ob;
  DregNet na = LoadDregWeights(a, &oa), nb = LoadDregWeights(b, &ob);
  const auto pa = na->parameters(), pb = nb->parameters();
  EXPECT_EQ(pa.size(), pb.size());
  double m = 0;
  for (size_t i = 0; i < pa.size() && i < pb.size(); ++i) m = std::max(m, (pa[i] - pb[i]).abs().max().item<double>());
  return m;
}

std::string MakeData(const ScopedTempDir& dir) {
  const CommandResult made =
      RunNerfreg("reg make-data --procedural 2 --mesh-pairs 1 --grid-resolution 32 --quiet --out " + dir.File("data"));
  EXPECT_EQ(made.exit_code, 0) << made.output;
  return dir.File("data/pairs.json");
}

TEST(DistCli, TwoProcessesMatchOneWithTheSameBatch) {
  ScopedTempDir dir;
  const std::string data = MakeData(dir);
  // Every augmentation on, so the pairs' draws must be split consistently across the ranks.
  const std::string common =
      "reg train " + data + " --iters 3 --val-every 0 --mirror 0.5 --recolour 0.5 --lr 1e-3 --quiet";
  const CommandResult one = RunShell("OMP_NUM_THREADS=1 " + std::string(NERFREG_BINARY) + " " + common +
                                     " --batch 2 --out " + dir.File("one.pt"));
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const CommandResult two = RunNerfreg(common + " --batch 2 --nproc 2 --out " + dir.File("two.pt"));
  ASSERT_EQ(two.exit_code, 0) << two.output;
  const CommandResult half = RunShell("OMP_NUM_THREADS=1 " + std::string(NERFREG_BINARY) + " " + common +
                                      " --batch 1 --out " + dir.File("half.pt"));
  ASSERT_EQ(half.exit_code, 0) << half.output;
  // One result on stdout (rank 0's), one log line per step.
  EXPECT_EQ(two.output.find("\"weights\""), two.output.rfind("\"weights\"")) << two.output;
  const CommandResult lines = RunShell("wc -l < " + dir.File("two.pt.log.jsonl"));
  EXPECT_EQ(std::stoi(lines.output), 3);
  const Json summary = ReadJsonFile(dir.File("two.pt.json"));
  EXPECT_EQ(summary["processes"].get<int>(), 2);

  const double two_vs_one = MaxWeightDifference(dir.File("one.pt"), dir.File("two.pt"));
  const double half_vs_one = MaxWeightDifference(dir.File("one.pt"), dir.File("half.pt"));
  EXPECT_LT(two_vs_one, 1e-5);
  // The batch's second pair mattered (a run that dropped rank 1's gradients would not match).
  EXPECT_GT(half_vs_one, 1e-4);
  EXPECT_LT(two_vs_one, half_vs_one / 100);
}

// The largest absolute difference over the parameters of two DBARF weights files (the BatchNorm
// running statistics aside: each process keeps its own, as DDP without buffer broadcast; DBARF's
// pose network runs on batch statistics).
double MaxDbarfParameterDifference(const std::string& a, const std::string& b) {
  const DbarfModel ma = LoadDbarfWeights(a), mb = LoadDbarfWeights(b);
  std::vector<torch::Tensor> pa = ma.NerfParameters(), pb = mb.NerfParameters();
  for (const auto& p : ma.PoseParameters()) pa.push_back(p);
  for (const auto& p : mb.PoseParameters()) pb.push_back(p);
  EXPECT_EQ(pa.size(), pb.size());
  double m = 0;
  for (size_t i = 0; i < pa.size() && i < pb.size(); ++i) m = std::max(m, (pa[i] - pb[i]).abs().max().item<double>());
  return m;
}

// dbarf pretrain --nproc 2: two Gloo processes, one target each, compute the steps one process
// computes with two targets a step, through pose, NeRF and pose stages (both optimisers), blurred
// targets drawn as well; the second target mattered.
TEST(DistCli, DbarfPretrainTwoProcessesMatchOneWithTheSameBatch) {
  ScopedTempDir dir;
  ASSERT_EQ(RunNerfreg("render --procedural 7 --trajectory forward --views 10 --test-every 5 --quiet --out " +
                       dir.File("data"))
                .exit_code,
            0);
  const std::string common = "dbarf pretrain " + dir.File("data/transforms.json") +
                             " --scene-cameras ground-truth --steps 3 --stage-steps 1 --rays 48 --sources 2 "
                             "--checkpoint-every 3 --augment-blur 0.5 --quiet";
  const std::string one_thread = "OMP_NUM_THREADS=1 " + std::string(NERFREG_BINARY) + " ";
  const CommandResult one = RunShell(one_thread + common + " --batch 2 --out " + dir.File("one.pt"));
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const CommandResult two = RunNerfreg(common + " --batch 2 --nproc 2 --out " + dir.File("two.pt"));
  ASSERT_EQ(two.exit_code, 0) << two.output;
  const CommandResult half = RunShell(one_thread + common + " --batch 1 --out " + dir.File("half.pt"));
  ASSERT_EQ(half.exit_code, 0) << half.output;
  // Rank 0 alone writes: one log line per step, one summary.
  EXPECT_EQ(std::stoi(RunShell("wc -l < " + dir.File("two.pt.log.jsonl")).output), 3);
  EXPECT_EQ(ReadJsonFile(dir.File("two.pt.json"))["processes"].get<int>(), 2);

  const double two_vs_one = MaxDbarfParameterDifference(dir.File("one.pt"), dir.File("two.pt"));
  const double half_vs_one = MaxDbarfParameterDifference(dir.File("one.pt"), dir.File("half.pt"));
  EXPECT_LT(two_vs_one, 1e-5);
  EXPECT_GT(half_vs_one, 1e-4);
  EXPECT_LT(two_vs_one, half_vs_one / 100);

  // Stopped after 2 steps and resumed by both ranks: the 3 steps of the run that did not stop.
  const std::string split = common + " --batch 2 --nproc 2 --out " + dir.File("split.pt");
  ASSERT_EQ(RunNerfreg(std::regex_replace(split, std::regex("--steps 3"), "--steps 2")).exit_code, 0);
  const CommandResult resumed = RunNerfreg(split + " --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_LT(MaxDbarfParameterDifference(dir.File("two.pt"), dir.File("split.pt")), 1e-5);
}

TEST(DistCli, AKilledRankEndsTheJobWithANamedErrorAndResumeContinues) {
  ScopedTempDir dir;
  const std::string data = MakeData(dir);
  const std::string train = std::string(NERFREG_BINARY) + " reg train " + data + " --out " + dir.File("w.pt") +
                            " --val-every 0 --checkpoint-every 1 --quiet --nproc 2";
  // Start the job, wait for its first checkpoint, SIGKILL rank 1 and time the launcher's end.
  const std::string script =
      train + " --iters 100000 > " + dir.File("job.txt") + " 2>&1 & L=$!\n" + "i=0; while [ ! -f " +
      dir.File("w.pt.train") + " ] && [ $i -lt 600 ]; do sleep 0.1; i=$((i+1)); done\n" +
      "for c in $(pgrep -P $L); do if tr '\\0' '\\n' < /proc/$c/environ | grep -qx RANK=1; then kill -9 $c; fi; "
      "done\n" +
      "s=$(date +%s%N); wait $L; rc=$?; e=$(date +%s%N)\n" + "echo \"rc=$rc ms=$(( (e - s) / 1000000 ))\"\n";
  WriteFileAtomic(dir.File("kill.sh"), script);
  const CommandResult killed = RunShell("sh " + dir.File("kill.sh"));
  const std::string job = RunShell("cat " + dir.File("job.txt")).output;
  ASSERT_NE(killed.output.find("rc=4 "), std::string::npos) << killed.output << job;
  const int ms = std::stoi(killed.output.substr(killed.output.find("ms=") + 3));
  EXPECT_LT(ms, 10000) << "the job took " << ms << " ms to end";
  EXPECT_NE(job.find("error: distributed: rank 1 (pid"), std::string::npos) << job;
  EXPECT_NE(job.find("killed by signal 9"), std::string::npos) << job;

  const int last_step = Json::parse(RunShell("tail -n 1 " + dir.File("w.pt.log.jsonl")).output)["step"].get<int>();
  ASSERT_GT(last_step, 0);
  const int target = last_step + 2;
  const CommandResult resumed = RunShell(train + " --iters " + std::to_string(target) + " --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_EQ(ReadJsonFile(dir.File("w.pt.json"))["iterations"].get<int>(), target);
  // It did not start again from zero: step 1 is logged once.
  EXPECT_EQ(RunShell("grep -c '\"step\":1,' " + dir.File("w.pt.log.jsonl")).output.substr(0, 1), "1");
}

}  // namespace
}  // namespace nerfreg
