#include "nerfreg/util/file_util.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include <atomic>
#include <cstdio>
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
    ThrowInputError(path, "size", "at most " + std::to_string(max_bytes) + " bytes, file has " +
                                      std::to_string(size));
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
  return (p.parent_path() / ("." + p.filename().string() + ".tmp." + std::to_string(::getpid()) +
                             "." + std::to_string(counter++)))
      .string();
}

// Temporary files of `path` left by a writer that was killed (SIGKILL cannot be caught, so its
// own clean-up never ran): ".NAME.tmp.PID.N" whose PID is no longer a running process. Removed by
// the next write of the same path, so a killed and resumed run ends with no leftovers.
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
    if (pid == ::getpid() || ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    fs::remove(entry.path(), ec);
  }
}

void FsyncPath(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}
}  // namespace

void WriteAtomically(const std::string& path,
                     const std::function<void(const std::string& tmp_path)>& write) {
  const std::string parent = ParentDir(path);
  if (!parent.empty()) CreateDirectories(parent);
  RemoveStaleTempFiles(path);
  const std::string tmp = TempPathFor(path);
  try {
    write(tmp);
    if (!fs::exists(tmp)) throw std::runtime_error("writer produced no file for " + path);
    FsyncPath(tmp);
    fs::rename(tmp, path);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
}

void WriteFileAtomic(const std::string& path, const std::string& contents) {
  WriteAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot open for writing");
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.flush();
    if (!out) throw InputError(path + ": write failed (disk full?)");
  });
}

void CheckCanWriteOutput(const std::string& path, bool force) {
  std::error_code ec;
  if (!force && fs::exists(path, ec)) {
    throw InputError(path + ": exists; pass --force to overwrite");
  }
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
