#pragma once
// Files: every output of the project is written atomically (temp file in the same directory, then
// rename), so a crash or SIGKILL never leaves a half-written output or checkpoint; existing
// outputs are refused unless the user passed --force.
#include <cstdint>
#include <functional>
#include <string>

namespace nerfreg {

// Largest file any parser reads whole into memory (1 GiB). Parsers check sizes against this
// before allocating so a corrupt header cannot request terabytes.
constexpr std::int64_t kMaxReadBytes = std::int64_t(1) << 30;

// Reads a whole file. Throws InputError naming the file when it is missing, unreadable or larger
// than max_bytes.
std::string ReadFileToString(const std::string& path, std::int64_t max_bytes = kMaxReadBytes);

// Writes `contents` to `path` atomically (temp + fsync + rename). Creates parent directories.
void WriteFileAtomic(const std::string& path, const std::string& contents);

// Calls write(tmp_path) to produce the file, then renames tmp_path to path. If write throws, the
// temp file is removed and `path` is untouched. For writers that need a path (stb, Open3D).
void WriteAtomically(const std::string& path,
                     const std::function<void(const std::string& tmp_path)>& write);

// Throws InputError("PATH: exists; pass --force to overwrite") when path exists and !force.
void CheckCanWriteOutput(const std::string& path, bool force);

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
