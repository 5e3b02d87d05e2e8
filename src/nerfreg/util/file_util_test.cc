#include "nerfreg/util/file_util.h"

#include <gtest/gtest.h>

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
