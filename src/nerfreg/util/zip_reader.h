#pragma once
// Reading entries out of a zip archive in memory, never onto disk (Sweet Home 3D's .sh3f furniture
// libraries are zips of OBJ + MTL + textures). Only what those archives use: stored (method 0) and
// deflated (8) entries, no encryption, no zip64, one disk. A hostile archive is refused with an
// InputError naming the archive and the entry, before anything large is allocated:
//  - entry names must be relative paths inside the archive (no leading '/', no drive letter, no
//    '\\', no ".." component, no NUL), so a name can never reach outside whatever folder a caller
//    maps the archive onto;
//  - uncompressed sizes are capped per entry and in total (declared sizes, checked when the
//    archive opens), and inflation stops at the declared size (a zip bomb that lies about its size
//    fails its size check, not the machine);
//  - every read entry's CRC-32 is checked.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace nerfreg {

struct ZipLimits {
  std::int64_t max_entry_bytes = std::int64_t(256) << 20;  // largest uncompressed entry, bytes
  std::int64_t max_total_bytes = std::int64_t(4) << 30;    // sum of declared uncompressed sizes, bytes
  std::int64_t max_entries = 100000;                       // entries in the central directory
  void Check() const;                                      // throws std::invalid_argument
};

struct ZipEntry {
  std::string name;                // as stored ("folder/file.obj"); folders end in '/'
  std::uint16_t method = 0;        // 0 stored, 8 deflated
  std::uint32_t crc32 = 0;         // of the uncompressed bytes
  std::int64_t compressed = 0;     // bytes in the archive
  std::int64_t uncompressed = 0;   // declared size, bytes
  std::int64_t header_offset = 0;  // of the local file header
};

class ZipReader {
 public:
  // Opens a zip file (its central directory is read now; entries when asked). Throws InputError
  // naming `path` on anything listed above.
  static ZipReader Open(const std::string& path, const ZipLimits& limits = ZipLimits());
  // The same from bytes in memory; `name` stands for the archive in errors.
  static ZipReader FromBytes(std::string bytes, const std::string& name, const ZipLimits& limits = ZipLimits());

  const std::string& name() const { return name_; }
  const std::vector<ZipEntry>& entries() const { return entries_; }
  // Whether an entry of that exact name exists (folders excluded).
  bool Has(const std::string& entry) const;
  // The uncompressed bytes of an entry. Throws InputError "ARCHIVE: ENTRY: expected ..." when it
  // is missing, oversized, truncated, undecodable or fails its CRC.
  std::string Read(const std::string& entry) const;

 private:
  ZipReader() = default;
  void ReadCentralDirectory();
  std::string ReadAt(std::int64_t offset, std::int64_t size, const std::string& what) const;

  std::string name_;
  std::string path_;   // the file read from, or empty when bytes_ holds the archive
  std::string bytes_;  // the whole archive (FromBytes)
  std::int64_t size_ = 0;
  ZipLimits limits_;
  std::vector<ZipEntry> entries_;
  std::map<std::string, size_t> index_;
};

// Resolves `relative` (a path from an OBJ or MTL, '/' or '\\' separated) against the folder
// `base` ("a/b/" or "") inside an archive: "." and ".." components are applied, and a path that
// climbs above the archive's root, is absolute or has a drive letter gives "" (no such entry).
std::string ResolveArchivePath(const std::string& base, const std::string& relative);

}  // namespace nerfreg
