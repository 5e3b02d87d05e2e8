#include "nerfreg/util/training_log.h"

#include <gtest/gtest.h>

#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A run killed at step 7 after a checkpoint at step 5, mid-way through a line: the resumed run
// (from step 5) finds the steps it will log again, and half a line, gone.
TEST(TrainingLog, RewindKeepsCompleteLinesUpToTheStateStep) {
  ScopedTempDir dir;
  const std::string log = dir.File("w.pt.log.jsonl");
  WriteFileAtomic(log,
                  "{\"step\":4,\"loss\":1}\n{\"step\":5,\"loss\":0.9}\n{\"note\":\"no step\"}\n"
                  "{\"step\":6,\"loss\":0.8}\n{\"step\":7,\"lo");
  EXPECT_EQ(RewindTrainingLog(log, 5), 2);
  EXPECT_EQ(ReadFileToString(log), "{\"step\":4,\"loss\":1}\n{\"step\":5,\"loss\":0.9}\n{\"note\":\"no step\"}\n");
  EXPECT_EQ(RewindTrainingLog(log, 5), 0);  // nothing more to drop: the file is left as it is
  EXPECT_EQ(RewindTrainingLog(dir.File("missing.jsonl"), 5), 0);
  EXPECT_FALSE(FileExists(dir.File("missing.jsonl")));
}

}  // namespace
}  // namespace nerfreg
