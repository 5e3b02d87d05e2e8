#pragma once
// Files: every output of the project is written atomically (temp file in the same directory, then
// rename), so a crash or SIGKILL never leaves a half-written output or checkpoint; existing
// outputs are refused unless the user passed --force.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace nerfreg {

// Largest file any parser reads whole into memory (1 GiB). Parsers check sizes against this
// before allocating so a corrupt header cannot request terabytes.
constexpr std::int64_t kMaxReadBytes = std::int64_t(1) << 30;

// Reads a whole file. Throws InputError naming the file when it is missing, unreadable or larger
// than max_bytes.
std::string ReadFileToString(const std::string& path, std::int64_t max_bytes = kMaxReadBytes);

// Writes `contents` to `path` atomically: a hidden temporary sibling, every write checked, fsync,
// then rename. Creates parent directories. A full disk (ENOSPC, EDQUOT, EFBIG) is the InputError
// "PATH: expected space to write (disk full?)", another failed write "PATH: expected a writable
// location (REASON)"; either way the temporary file is removed and `path` is untouched. A path
// checked by CheckCanWriteOutput without --force is created without replacing: if another process
// wrote it meanwhile this write fails ("exists") rather than silently replacing that result.
void WriteFileAtomic(const std::string& path, const std::string& contents);

// Calls write(tmp_path) to produce the file, then moves it into place as WriteFileAtomic does. If
// write throws, the temp file is removed and `path` is untouched. Prefer WriteFileAtomic with an
// in-memory buffer: a writer given a path may not report a failed write.
void WriteAtomically(const std::string& path, const std::function<void(const std::string& tmp_path)>& write);

// Checks an output path before any work starts:
//  - empty: "--out: expected a path";
//  - it is one of `inputs` (or, for a folder, holds one): refused even with --force;
//  - it exists and !force: "PATH: exists; pass --force to overwrite";
//  - its folder cannot be written (read-only, no such permission): found now, not after the work.
// Without --force the path is remembered, so its first write will not replace a file another
// process wrote meanwhile (two runs to one output cannot both succeed).
void CheckCanWriteOutput(const std::string& path, bool force, const std::vector<std::string>& inputs = {});

// The file that marks a folder as written by nerfreg; --force replaces only folders that have it.
constexpr const char* kOutputMarker = ".nerfreg-output";

// An output folder, built as a hidden temporary sibling (".NAME.tmp.PID.N") and moved into place
// whole by Commit(), so a killed run never leaves a half-written folder under the real name. The
// constructor checks the output as CheckCanWriteOutput does, and with --force also that an
// existing folder is a nerfreg output (it has kOutputMarker): anything else is never deleted.
// Commit() fails, keeping the other result, when another process created the folder meanwhile and
// force is false. Not committed: the temporary folder is removed by the destructor.
class OutputDir {
 public:
  OutputDir(const std::string& out, bool force, const std::vector<std::string>& inputs = {});
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  const std::string& out() const { return out_; }
  const std::string& tmp() const { return tmp_; }
  // `relative` inside the temporary folder, e.g. Path("images/r_000.png").
  std::string Path(const std::string& relative) const;
  void Commit();

 private:
  std::string out_, tmp_;
  bool force_ = false;
  bool committed_ = false;
  int slot_ = -1;
};

// SIGINT and SIGTERM: temporary files being written are removed and the process exits with
// 128 + the signal (130, 143); every finished output and checkpoint was renamed into place whole,
// so the last one stays loadable. SIGXFSZ is ignored so that a file-size limit is a failed write
// (EFBIG, reported as a full disk) rather than a crash. Called once by main.
void InstallOutputSignalHandlers();

// Creates a directory (and parents). Throws InputError when path exists as a non-directory.
void CreateDirectories(const std::string& path);

bool FileExists(const std::string& path);
bool DirExists(const std::string& path);

// Joins path components with '/', ignoring empty ones.
std::string JoinPaths(const std::string& a, const std::string& b);

// Directory part of a path ("" for a bare file name), and extension in lower case with the dot.
std::string ParentDir(const std::string& path);
std::string LowerExtension(const std::string& path);

}  // namespace nerfreg
