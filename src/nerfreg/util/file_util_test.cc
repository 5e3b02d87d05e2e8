#include "nerfreg/util/file_util.h"

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>

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
  const std::string dead = dir.File(".x.json.tmp.2147483646.3"),
                    live = dir.File(".x.json.tmp." + std::to_string(::getpid()) + ".99");
  const std::string other = dir.File(".y.json.tmp.2147483646.3");
  for (const auto& f : {dead, live, other}) WriteFileAtomic(f, "partial");
  WriteFileAtomic(dir.File("x.json"), "{}");
  EXPECT_FALSE(std::filesystem::exists(dead));
  EXPECT_TRUE(std::filesystem::exists(live));
  EXPECT_TRUE(std::filesystem::exists(other));  // another file's
}

// A killed writer's PID may be taken by another process before the next write (under a parallel
// test run, within seconds): a temporary file whose PID belongs to a process started after the
// file was written is stale too.
TEST(FileUtil, TempFilesOfAReusedPidAreStale) {
  ScopedTempDir dir;
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::pause();
    ::_exit(0);
  }
  const std::string reused = dir.File(".x.json.tmp." + std::to_string(child) + ".0");
  WriteFileAtomic(reused, "partial");
  namespace fs = std::filesystem;
  fs::last_write_time(reused, fs::last_write_time(reused) - std::chrono::seconds(60));
  WriteFileAtomic(dir.File("x.json"), "{}");
  EXPECT_FALSE(fs::exists(reused));
  // Written while it ran: its own.
  const std::string own = dir.File(".x.json.tmp." + std::to_string(child) + ".1");
  WriteFileAtomic(own, "partial");
  WriteFileAtomic(dir.File("x.json"), "{}");
  EXPECT_TRUE(fs::exists(own));
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
}

// A killed writer not yet reaped (a zombie: kill(pid, 0) still finds it) left its file.
TEST(FileUtil, TempFilesOfAZombieAreStale) {
  ScopedTempDir dir;
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) ::_exit(0);
  // Not reaped until the end: wait for the kernel to make it a zombie.
  const std::string stat_path = "/proc/" + std::to_string(child) + "/stat";
  bool zombie = false;
  for (int i = 0; i < 500 && !zombie; ++i) {
    std::ifstream stat_file(stat_path);  // /proc files report size 0: read as a stream
    std::string line;
    zombie = std::getline(stat_file, line) && line.find(") Z ") != std::string::npos;
    if (!zombie) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(zombie);
  ASSERT_EQ(::kill(child, 0), 0);
  const std::string left = dir.File(".x.json.tmp." + std::to_string(child) + ".0");
  WriteFileAtomic(left, "partial");
  WriteFileAtomic(dir.File("x.json"), "{}");
  EXPECT_FALSE(std::filesystem::exists(left));
  ::waitpid(child, nullptr, 0);
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

namespace fs = std::filesystem;

int CountEntries(const std::string& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    (void)e;
    ++n;
  }
  return n;
}

// Runs f in a child process whose files may not grow past `max_bytes` (RLIMIT_FSIZE: the kernel
// then fails writes with EFBIG, as a full disk fails them with ENOSPC). Returns the message of the
// InputError f threw, "" if none, or "crash" if the child died.
std::string InputErrorUnderFileSizeLimit(rlim_t max_bytes, const std::function<void()>& f) {
  int fds[2];
  if (::pipe(fds) != 0) return "pipe";
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit limit{max_bytes, max_bytes};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    const std::string message = InputErrorOf(f);
    if (::write(fds[1], message.data(), message.size()) < 0) ::_exit(4);
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string message;
  char buffer[512];
  for (ssize_t n; (n = ::read(fds[0], buffer, sizeof(buffer))) > 0;) message.append(buffer, static_cast<size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return "crash";
  return message;
}

TEST(FileUtil, FullDiskIsAnInputErrorAndLeavesTheOldFileAndNoTemp) {
  ScopedTempDir dir;
  const std::string path = dir.File("out.bin");
  WriteFileAtomic(path, "old");
  const std::string message =
      InputErrorUnderFileSizeLimit(4096, [&] { WriteFileAtomic(path, std::string(100000, 'x')); });
  EXPECT_NE(message.find("out.bin: expected space to write (disk full?)"), std::string::npos) << message;
  EXPECT_EQ(ReadFileToString(path), "old");
  EXPECT_EQ(CountEntries(dir.path()), 1);  // no temporary file left
}

TEST(FileUtil, OutputChecksRefuseInputsEmptyPathsAndUnwritableFolders) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("data/transforms.json"), "{}");
  // The output is an input, or a folder holding one: refused even with --force.
  EXPECT_NE(InputErrorOf([&] {
              CheckCanWriteOutput(dir.File("data/transforms.json"), true, {dir.File("data/transforms.json")});
            }),
            "");
  EXPECT_NE(InputErrorOf([&] { CheckCanWriteOutput(dir.File("data"), true, {dir.File("data/transforms.json")}); }), "");
  EXPECT_NE(InputErrorOf([&] { CheckCanWriteOutput(dir.File("data/../data"), true, {dir.File("data")}); }), "");
  // A sibling of an input is fine.
  EXPECT_EQ(
      InputErrorOf([&] { CheckCanWriteOutput(dir.File("data/out.json"), false, {dir.File("data/transforms.json")}); }),
      "");
  EXPECT_NE(InputErrorOf([] { CheckCanWriteOutput("", true); }).find("--out: expected a path"), std::string::npos);
  // A parent that is a file cannot hold the output.
  EXPECT_NE(InputErrorOf([&] { CheckCanWriteOutput(dir.File("data/transforms.json/x"), false); }), "");
}

// Two runs to one new output: the second to finish must not replace the first's result.
TEST(FileUtil, ANewFileOutputIsNotReplacedByAnotherRunsWrite) {
  ScopedTempDir dir;
  const std::string path = dir.File("t.json");
  CheckCanWriteOutput(path, false);  // this run: t.json does not exist yet
  {
    // Another process writes t.json meanwhile (outside this process's bookkeeping).
    FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fputs("theirs", f);
    std::fclose(f);
  }
  EXPECT_NE(InputErrorOf([&] { WriteFileAtomic(path, "ours"); }).find("another run wrote it meanwhile"),
            std::string::npos);
  EXPECT_EQ(ReadFileToString(path), "theirs");
  EXPECT_EQ(CountEntries(dir.path()), 1);  // no temporary file
  // A path this run created itself is then replaced by its later writes (checkpoints).
  const std::string ckpt = dir.File("b.ckpt");
  CheckCanWriteOutput(ckpt, false);
  WriteFileAtomic(ckpt, "step 100");
  WriteFileAtomic(ckpt, "step 200");
  EXPECT_EQ(ReadFileToString(ckpt), "step 200");
}

TEST(FileUtil, OutputDirAppearsWholeAndForceReplacesOnlyNerfregFolders) {
  ScopedTempDir dir;
  const std::string out = dir.File("run");
  {
    OutputDir o(out, false);
    WriteFileAtomic(o.Path("a.txt"), "1");
    EXPECT_FALSE(fs::exists(out));  // nothing under the real name before Commit
    o.Commit();
  }
  EXPECT_EQ(ReadFileToString(out + "/a.txt"), "1");
  EXPECT_TRUE(fs::exists(out + "/" + kOutputMarker));
  EXPECT_EQ(CountEntries(dir.path()), 1);
  // Without --force: refused. With it: replaced whole (the old file is gone).
  EXPECT_NE(InputErrorOf([&] { OutputDir o(out, false); }).find("exists; pass --force"), std::string::npos);
  {
    OutputDir o(out, true);
    WriteFileAtomic(o.Path("b.txt"), "2");
    o.Commit();
  }
  EXPECT_FALSE(fs::exists(out + "/a.txt"));
  EXPECT_EQ(ReadFileToString(out + "/b.txt"), "2");
  EXPECT_EQ(CountEntries(dir.path()), 1);
  // A folder nerfreg did not write is never deleted, even with --force.
  const std::string mine = dir.File("photos");
  WriteFileAtomic(mine + "/holiday.jpg", "precious");
  const std::string message = InputErrorOf([&] { OutputDir o(mine, true); });
  EXPECT_NE(message.find("photos: expected a folder written by nerfreg"), std::string::npos) << message;
  EXPECT_EQ(ReadFileToString(mine + "/holiday.jpg"), "precious");
  // An output folder that holds an input is refused even when nerfreg wrote it.
  EXPECT_NE(InputErrorOf([&] { OutputDir o(out, true, {out + "/b.txt"}); }), "");
  // Not committed (an error, a crash unwinding): the temporary folder goes, the old output stays.
  try {
    OutputDir o(out, true);
    WriteFileAtomic(o.Path("c.txt"), "3");
    throw std::runtime_error("failed half-way");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(ReadFileToString(out + "/b.txt"), "2");
  EXPECT_EQ(CountEntries(dir.path()), 2);  // run, photos
}

TEST(FileUtil, TwoRunsToOneNewOutputFolderCannotBothSucceed) {
  ScopedTempDir dir;
  const std::string out = dir.File("poses");
  OutputDir first(out, false), second(out, false);  // both checked while it did not exist
  WriteFileAtomic(first.Path("x"), "first");
  WriteFileAtomic(second.Path("x"), "second");
  first.Commit();
  EXPECT_NE(InputErrorOf([&] { second.Commit(); }).find("another run wrote it meanwhile"), std::string::npos);
  EXPECT_EQ(ReadFileToString(out + "/x"), "first");
}

TEST(FileUtil, StaleTemporaryFoldersOfDeadRunsAreRemoved) {
  ScopedTempDir dir;
  const std::string stale = dir.File(".run.tmp.2147483646.0");
  WriteFileAtomic(stale + "/half.png", "x");
  {
    OutputDir o(dir.File("run"), false);
    o.Commit();
  }
  EXPECT_FALSE(fs::exists(stale));
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
