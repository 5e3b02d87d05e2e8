#include "nerfreg/util/file_util.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include "nerfreg/util/error.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(FileUtil, AtomicWriteRoundTripAndNoTempLeft) {
  ScopedTempDir dir;
  const std::string path = dir.File("sub/out.txt");
  WriteFileAtomic(path, "hello");
  EXPECT_EQ(ReadFileToString(path), "hello");
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path() + "/sub")) {
    (void)e;
    ++n;
  }
  EXPECT_EQ(n, 1);
}

// A writer killed with SIGKILL leaves its temporary file; the next write of the same path removes
// it when its process is gone, and leaves those of live processes (this one) alone.
TEST(FileUtil, NextWriteRemovesTempFilesOfDeadWriters) {
  ScopedTempDir dir;
  const std::string dead = dir.File(".x.json.tmp.2147483646.3"), live = dir.File(".x.json.tmp." + std::to_string(::getpid()) + ".99");
  const std::string other = dir.File(".y.json.tmp.2147483646.3");
  for (const auto& f : {dead, live, other}) WriteFileAtomic(f, "partial");
  WriteFileAtomic(dir.File("x.json"), "{}");
  EXPECT_FALSE(std::filesystem::exists(dead));
  EXPECT_TRUE(std::filesystem::exists(live));
  EXPECT_TRUE(std::filesystem::exists(other));  // another file's
}

TEST(FileUtil, FailedWriterLeavesOldFileUntouched) {
  ScopedTempDir dir;
  const std::string path = dir.File("out.txt");
  WriteFileAtomic(path, "old");
  EXPECT_THROW(WriteAtomically(path,
                               [](const std::string& tmp) {
                                 WriteFileAtomic(tmp, "partial");
                                 throw std::runtime_error("crash in the middle");
                               }),
               std::runtime_error);
  EXPECT_EQ(ReadFileToString(path), "old");
  EXPECT_FALSE(FileExists(dir.File(".out.txt.tmp")));
}

TEST(FileUtil, RefusesOverwriteWithoutForce) {
  ScopedTempDir dir;
  const std::string path = dir.File("out.txt");
  EXPECT_NO_THROW(CheckCanWriteOutput(path, false));
  WriteFileAtomic(path, "x");
  EXPECT_THROW(CheckCanWriteOutput(path, false), InputError);
  EXPECT_NO_THROW(CheckCanWriteOutput(path, true));
}

TEST(FileUtil, ReadErrorsNameTheFile) {
  ScopedTempDir dir;
  try {
    ReadFileToString(dir.File("missing.json"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.json"), std::string::npos);
  }
  WriteFileAtomic(dir.File("big"), std::string(100, 'a'));
  EXPECT_THROW(ReadFileToString(dir.File("big"), 10), InputError);
}

}  // namespace
}  // namespace nerfreg
