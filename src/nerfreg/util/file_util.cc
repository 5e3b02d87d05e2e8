#include "nerfreg/util/file_util.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "nerfreg/util/error.h"

namespace fs = std::filesystem;

namespace nerfreg {

std::string ReadFileToString(const std::string& path, std::int64_t max_bytes) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) ThrowInputError(path, "", "an existing regular file");
  const auto size = static_cast<std::int64_t>(fs::file_size(path, ec));
  if (ec) ThrowInputError(path, "", "a readable file");
  if (size > max_bytes) {
    ThrowInputError(path, "size", "at most " + std::to_string(max_bytes) + " bytes, file has " + std::to_string(size));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError(path, "", "a readable file");
  std::string data(static_cast<size_t>(size), '\0');
  in.read(data.data(), size);
  if (in.gcount() != size) ThrowInputError(path, "", "a readable file (short read)");
  return data;
}

namespace {
std::string TempPathFor(const std::string& path) {
  static std::atomic<int> counter{0};
  const fs::path p(path);
  return (p.parent_path() /
          ("." + p.filename().string() + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++)))
      .string();
}

// Whether the process (or thread) `pid` cannot be the writer of a file last written at `written`
// (its modification time), though kill(pid, 0) finds it:
//  - it is a zombie (state Z): dead, its files closed, only not yet reaped; a killed writer whose
//    parent is gone stays one where PID 1 does not reap (containers);
//  - it started after `written`: another process that took the PID (PIDs and thread ids are
//    reused, under a parallel test run within seconds). /proc/PID/stat's start time is in clock
//    ticks since boot; the file's time is brought onto that clock through the clocks' current
//    offset. 50 ms of margin covers the ticks (10 ms) and the two clock reads.
// False where it cannot tell.
bool NotTheWriter(long pid, const struct timespec& written) {
  std::ifstream stat_file("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat_file, line)) return false;
  const size_t close = line.rfind(')');  // the command name may hold spaces and ')'
  if (close == std::string::npos || close + 2 > line.size()) return false;
  std::istringstream fields(line.substr(close + 2));
  std::string state;
  if (!(fields >> state)) return false;  // field 3
  if (state == "Z" || state == "X") return true;
  std::string field;
  for (int k = 4; k < 22; ++k)  // fields 4..21, then the start time (field 22)
    if (!(fields >> field)) return false;
  unsigned long long start_ticks = 0;
  if (!(fields >> start_ticks)) return false;
  const long ticks_per_s = ::sysconf(_SC_CLK_TCK);
  struct timespec boot_now, real_now;
  if (ticks_per_s <= 0 || ::clock_gettime(CLOCK_BOOTTIME, &boot_now) != 0 ||
      ::clock_gettime(CLOCK_REALTIME, &real_now) != 0)
    return false;
  const auto seconds = [](const struct timespec& t) { return static_cast<double>(t.tv_sec) + 1e-9 * t.tv_nsec; };
  const double written_since_boot = seconds(written) - (seconds(real_now) - seconds(boot_now));
  return static_cast<double>(start_ticks) / ticks_per_s > written_since_boot + 0.05;
}

// Temporary files and folders of `path` left by a writer that was killed (SIGKILL cannot be
// caught, so its own clean-up never ran): ".NAME.tmp.PID.N" whose PID is no longer a running
// process, or is a zombie or one that started after the file was written. Removed by the next write of the
// same path, so a killed and resumed run ends with no leftovers.
void RemoveStaleTempFiles(const std::string& path) {
  const fs::path p(path);
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  const std::string prefix = "." + p.filename().string() + ".tmp.";
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = name.substr(prefix.size());  // "PID.N"
    char* end = nullptr;
    const long pid = std::strtol(rest.c_str(), &end, 10);
    if (end == rest.c_str() || *end != '.' || pid <= 0) continue;
    if (pid == ::getpid()) continue;
    const bool gone = ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
    struct stat info;
    if (!gone && !(::lstat(entry.path().c_str(), &info) == 0 && NotTheWriter(pid, info.st_mtim))) continue;
    fs::remove_all(entry.path(), ec);
  }
}

// Temporary paths being written, for the signal handler, which may only call async-signal-safe
// functions: fixed slots of C strings, claimed and released with atomics.
constexpr int kTempSlots = 64;
constexpr size_t kTempPathMax = 4096;
struct TempSlot {
  std::atomic<int> state{0};  // 0 free, 1 claimed (being filled), 2 a file, 3 a folder
  char path[kTempPathMax];
};
TempSlot g_temp_slots[kTempSlots];

int RegisterTemp(const std::string& path, bool folder) {
  if (path.size() >= kTempPathMax) return -1;
  for (int i = 0; i < kTempSlots; ++i) {
    int expected = 0;
    if (!g_temp_slots[i].state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_temp_slots[i].path, path.c_str(), path.size() + 1);
    g_temp_slots[i].state.store(folder ? 3 : 2);
    return i;
  }
  return -1;  // more than kTempSlots writes at once: this one is left to the stale-file sweep
}

void ReleaseTemp(int slot) {
  if (slot >= 0) g_temp_slots[slot].state.store(0);
}

void OnTerminationSignal(int sig) {
  for (auto& slot : g_temp_slots) {
    // A folder's contents cannot be removed safely here; the next run's sweep removes it.
    if (slot.state.load() == 2) ::unlink(slot.path);
  }
  ::_exit(128 + sig);
}

// Paths checked by CheckCanWriteOutput without --force: their first write must not replace.
std::mutex g_new_outputs_mutex;
std::set<std::string> g_new_outputs;

std::string Canonical(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) p = fs::absolute(path).lexically_normal();
  std::string s = p.string();
  while (s.size() > 1 && s.back() == '/') s.pop_back();
  return s;
}

bool TakeNewOutput(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_new_outputs_mutex);
  return g_new_outputs.erase(Canonical(path)) > 0;
}

// Output folders being built: temporary folder -> the output it becomes. Errors name a file
// inside one by its final name, which is the one the user gave.
std::mutex g_output_dirs_mutex;
std::map<std::string, std::string> g_output_dirs;

std::string DisplayPath(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_output_dirs_mutex);
  for (const auto& [tmp, out] : g_output_dirs) {
    if (path.compare(0, tmp.size(), tmp) == 0 && (path.size() == tmp.size() || path[tmp.size()] == '/')) {
      return out + path.substr(tmp.size());
    }
  }
  return path;
}

[[noreturn]] void ThrowWriteError(const std::string& path_in, int err) {
  const std::string path = DisplayPath(path_in);
  if (err == ENOSPC || err == EDQUOT || err == EFBIG) ThrowInputError(path, "", "space to write (disk full?)");
  ThrowInputError(path, "", std::string("a writable location (") + std::strerror(err) + ")");
}

void WriteAllOrThrow(const std::string& final_path, const std::string& tmp, const std::string& contents) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) ThrowWriteError(final_path, errno);
  size_t done = 0;
  while (done < contents.size()) {
    const ssize_t n = ::write(fd, contents.data() + done, contents.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      ThrowWriteError(final_path, err);
    }
    done += static_cast<size_t>(n);
  }
  // A delayed write error (NFS, a thin-provisioned disk) shows up only at fsync or close.
  if (::fsync(fd) != 0 && errno != EINVAL) {
    const int err = errno;
    ::close(fd);
    ThrowWriteError(final_path, err);
  }
  if (::close(fd) != 0) ThrowWriteError(final_path, errno);
}

void FsyncPath(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

// Moves a finished temporary file into place. `no_replace`: fail if `path` exists (a hard link
// cannot replace, so the check and the move are one atomic step).
void MoveIntoPlace(const std::string& tmp, const std::string& path, bool no_replace) {
  if (no_replace) {
    if (::link(tmp.c_str(), path.c_str()) == 0) {
      ::unlink(tmp.c_str());
      return;
    }
    if (errno == EEXIST)
      ThrowInputError(path, "", "a new output, but another run wrote it meanwhile; pass --force to overwrite");
    if (errno != EPERM && errno != ENOTSUP && errno != EOPNOTSUPP) ThrowWriteError(path, errno);
    // A file system without hard links: fall through to rename.
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) ThrowWriteError(path, errno);
}

// renameat2 (Linux 3.15): RENAME_NOREPLACE / RENAME_EXCHANGE. Returns -1 with errno EINVAL or
// ENOSYS where the file system does not support the flag.
int Rename2(const std::string& from, const std::string& to, unsigned flags) {
  return static_cast<int>(::syscall(SYS_renameat2, AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), flags));
}
constexpr unsigned kRenameNoReplace = 1u << 0;
constexpr unsigned kRenameExchange = 1u << 1;

bool IsOrHolds(const std::string& outer_canonical, const std::string& inner_canonical) {
  if (inner_canonical == outer_canonical) return true;
  return inner_canonical.size() > outer_canonical.size() &&
         inner_canonical.compare(0, outer_canonical.size(), outer_canonical) == 0 &&
         (outer_canonical == "/" || inner_canonical[outer_canonical.size()] == '/');
}

// The nearest existing folder at or above `path`'s folder can be written: checked by creating and
// removing a probe file (access(2) says yes to root on a read-only mount's folders... and no to
// nothing else; a real create answers for every case).
void CheckFolderWritable(const std::string& path) {
  fs::path dir = fs::absolute(path).parent_path();
  std::error_code ec;
  while (!dir.empty() && !fs::exists(dir, ec)) dir = dir.parent_path();
  if (dir.empty()) return;
  if (!fs::is_directory(dir, ec))
    ThrowInputError(path, "", "a path whose parent is a folder (" + dir.string() + " is a file)");
  const std::string probe = (dir / (".nerfreg-probe." + std::to_string(::getpid()))).string();
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    if (errno == EEXIST) return;
    ThrowInputError(path, "", std::string("a writable location (") + dir.string() + ": " + std::strerror(errno) + ")");
  }
  ::close(fd);
  ::unlink(probe.c_str());
}
}  // namespace

void WriteAtomically(const std::string& path, const std::function<void(const std::string& tmp_path)>& write) {
  const std::string parent = ParentDir(path);
  if (!parent.empty()) CreateDirectories(parent);
  RemoveStaleTempFiles(path);
  const std::string tmp = TempPathFor(path);
  const int slot = RegisterTemp(tmp, false);
  try {
    write(tmp);
    if (!fs::exists(tmp)) throw std::runtime_error("writer produced no file for " + path);
    FsyncPath(tmp);
    MoveIntoPlace(tmp, path, TakeNewOutput(path));
  } catch (const fs::filesystem_error& e) {
    std::error_code ec;
    fs::remove(tmp, ec);
    ReleaseTemp(slot);
    ThrowWriteError(path, e.code().value());
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    ReleaseTemp(slot);
    throw;
  }
  ReleaseTemp(slot);
}

void WriteFileAtomic(const std::string& path, const std::string& contents) {
  WriteAtomically(path, [&](const std::string& tmp) { WriteAllOrThrow(path, tmp, contents); });
}

void CheckCanWriteOutput(const std::string& path, bool force, const std::vector<std::string>& inputs) {
  if (path.empty()) ThrowInputError("--out", "", "a path (got an empty one)");
  const std::string out = Canonical(path);
  for (const auto& input : inputs) {
    if (input.empty()) continue;
    if (IsOrHolds(out, Canonical(input))) {
      ThrowInputError(path, "", "an output that is not an input and holds none (" + input + " is read from there)");
    }
  }
  std::error_code ec;
  const bool exists = fs::exists(fs::symlink_status(path, ec));
  if (exists && !force) throw InputError(path + ": exists; pass --force to overwrite");
  CheckFolderWritable(path);
  if (!exists) {
    std::lock_guard<std::mutex> lock(g_new_outputs_mutex);
    g_new_outputs.insert(out);
  }
}

OutputDir::OutputDir(const std::string& out, bool force, const std::vector<std::string>& inputs)
    : out_(out), force_(force) {
  if (!out_.empty() && out_.size() > 1 && out_.back() == '/') out_.pop_back();
  CheckCanWriteOutput(out_, force, inputs);
  std::error_code ec;
  if (fs::exists(out_, ec)) {
    if (!fs::is_directory(out_, ec))
      ThrowInputError(out_, "", "an output folder (a file of that name exists; remove it yourself)");
    if (!fs::exists(fs::path(out_) / kOutputMarker, ec) && !fs::is_empty(out_, ec)) {
      ThrowInputError(out_, "",
                      std::string("a folder written by nerfreg to replace with --force (it has no ") + kOutputMarker +
                          "; nerfreg deletes only what it wrote: remove or rename it yourself)");
    }
  }
  const std::string parent = ParentDir(out_);
  if (!parent.empty()) CreateDirectories(parent);
  RemoveStaleTempFiles(out_);
  tmp_ = TempPathFor(out_);
  slot_ = RegisterTemp(tmp_, true);
  fs::create_directory(tmp_, ec);
  if (ec) {
    ReleaseTemp(slot_);
    ThrowWriteError(out_, ec.value());
  }
  std::lock_guard<std::mutex> lock(g_output_dirs_mutex);
  g_output_dirs[tmp_] = out_;
}

OutputDir::~OutputDir() {
  {
    std::lock_guard<std::mutex> lock(g_output_dirs_mutex);
    g_output_dirs.erase(tmp_);
  }
  if (!committed_ && !tmp_.empty()) {
    std::error_code ec;
    fs::remove_all(tmp_, ec);
  }
  ReleaseTemp(slot_);
}

std::string OutputDir::Path(const std::string& relative) const { return JoinPaths(tmp_, relative); }

void OutputDir::Commit() {
  WriteFileAtomic(Path(kOutputMarker), "Written by nerfreg. With --force, nerfreg replaces this folder whole.\n");
  FsyncPath(tmp_);
  std::error_code ec;
  TakeNewOutput(out_);  // the no-replace rule below covers it
  const bool exists = fs::exists(fs::symlink_status(out_, ec));
  if (!exists) {
    if (Rename2(tmp_, out_, kRenameNoReplace) != 0) {
      if (errno == EEXIST || errno == ENOTEMPTY) {
        ThrowInputError(out_, "", "a new output, but another run wrote it meanwhile; pass --force to overwrite");
      }
      if (errno != EINVAL && errno != ENOSYS) ThrowWriteError(out_, errno);
      // No RENAME_NOREPLACE here: a folder still cannot replace a non-empty one.
      if (::rename(tmp_.c_str(), out_.c_str()) != 0) {
        if (errno == EEXIST || errno == ENOTEMPTY) {
          ThrowInputError(out_, "", "a new output, but another run wrote it meanwhile; pass --force to overwrite");
        }
        ThrowWriteError(out_, errno);
      }
    }
  } else {
    if (!force_)
      ThrowInputError(out_, "", "a new output, but another run wrote it meanwhile; pass --force to overwrite");
    if (!fs::is_directory(out_, ec) || (!fs::exists(fs::path(out_) / kOutputMarker, ec) && !fs::is_empty(out_, ec))) {
      ThrowInputError(
          out_, "",
          std::string("a folder written by nerfreg to replace with --force (it has no ") + kOutputMarker + ")");
    }
    // Swap the two folders in one step, then delete the old one (now under the temporary name).
    if (Rename2(tmp_, out_, kRenameExchange) != 0) {
      if (errno != EINVAL && errno != ENOSYS) ThrowWriteError(out_, errno);
      const std::string old = TempPathFor(out_);
      if (::rename(out_.c_str(), old.c_str()) != 0) ThrowWriteError(out_, errno);
      if (::rename(tmp_.c_str(), out_.c_str()) != 0) {
        const int err = errno;
        ::rename(old.c_str(), out_.c_str());
        ThrowWriteError(out_, err);
      }
      fs::remove_all(old, ec);
      committed_ = true;
      return;
    }
    fs::remove_all(tmp_, ec);  // the old output
  }
  committed_ = true;
  const std::string parent = ParentDir(out_);
  FsyncPath(parent.empty() ? "." : parent);
}

void InstallOutputSignalHandlers() {
  struct sigaction sa {};
  sa.sa_handler = OnTerminationSignal;
  sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  ::signal(SIGXFSZ, SIG_IGN);
}

void CreateDirectories(const std::string& path) {
  std::error_code ec;
  if (fs::exists(path, ec) && !fs::is_directory(path, ec)) {
    ThrowInputError(path, "", "a directory (a file of that name exists)");
  }
  fs::create_directories(path, ec);
  if (ec) throw InputError(path + ": cannot create directory: " + ec.message());
}

bool FileExists(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

bool DirExists(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

std::string JoinPaths(const std::string& a, const std::string& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return (fs::path(a) / fs::path(b)).string();
}

std::string ParentDir(const std::string& path) { return fs::path(path).parent_path().string(); }

std::string LowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace nerfreg
