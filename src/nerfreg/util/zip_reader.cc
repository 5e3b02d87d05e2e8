#include "nerfreg/util/zip_reader.h"

#include <zlib.h>

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

void ZipLimits::Check() const {
  if (max_entry_bytes <= 0 || max_total_bytes <= 0 || max_entries <= 0) {
    throw std::invalid_argument("ZipLimits: limits must be positive");
  }
}

namespace {

constexpr std::uint32_t kEndSignature = 0x06054b50;
constexpr std::uint32_t kCentralSignature = 0x02014b50;
constexpr std::uint32_t kLocalSignature = 0x04034b50;
constexpr std::int64_t kEndSize = 22;
constexpr std::int64_t kCentralSize = 46;
constexpr std::int64_t kLocalSize = 30;

std::uint16_t U16(const std::string& b, size_t at) {
  return static_cast<std::uint16_t>(static_cast<unsigned char>(b[at]) | static_cast<unsigned char>(b[at + 1]) << 8);
}
std::uint32_t U32(const std::string& b, size_t at) {
  return U16(b, at) | static_cast<std::uint32_t>(U16(b, at + 2)) << 16;
}

// Why an entry name is refused, or "" when it is a safe relative path.
std::string NameProblem(const std::string& name) {
  if (name.empty()) return "a non-empty name";
  if (name.find('\0') != std::string::npos) return "a name without NUL bytes";
  if (name[0] == '/' || name.find('\\') != std::string::npos) return "a relative '/'-separated path";
  if (name.size() >= 2 && name[1] == ':') return "a relative path (no drive letter)";
  std::stringstream parts(name);
  for (std::string part; std::getline(parts, part, '/');) {
    if (part == "..") return "a path inside the archive (no \"..\" component)";
  }
  return "";
}

}  // namespace

ZipReader ZipReader::Open(const std::string& path, const ZipLimits& limits) {
  limits.Check();
  if (!FileExists(path)) ThrowInputError(path, "", "an existing zip archive");
  ZipReader z;
  z.name_ = path;
  z.path_ = path;
  z.limits_ = limits;
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) ThrowInputError(path, "", "a readable zip archive");
  z.size_ = static_cast<std::int64_t>(in.tellg());
  z.ReadCentralDirectory();
  return z;
}

ZipReader ZipReader::FromBytes(std::string bytes, const std::string& name, const ZipLimits& limits) {
  limits.Check();
  ZipReader z;
  z.name_ = name;
  z.bytes_ = std::move(bytes);
  z.size_ = static_cast<std::int64_t>(z.bytes_.size());
  z.limits_ = limits;
  z.ReadCentralDirectory();
  return z;
}

std::string ZipReader::ReadAt(std::int64_t offset, std::int64_t size, const std::string& what) const {
  if (offset < 0 || size < 0 || offset > size_ || size > size_ - offset) {
    ThrowInputError(name_, what, "bytes within the archive (it ends at " + std::to_string(size_) + ")");
  }
  if (path_.empty()) return bytes_.substr(static_cast<size_t>(offset), static_cast<size_t>(size));
  std::ifstream in(path_, std::ios::binary);
  std::string out(static_cast<size_t>(size), '\0');
  in.seekg(offset);
  if (!in.read(out.data(), size)) ThrowInputError(name_, what, "a readable archive");
  return out;
}

void ZipReader::ReadCentralDirectory() {
  if (size_ < kEndSize) ThrowInputError(name_, "", "a zip archive (too short for its end record)");
  // The end record is the last 22 bytes plus a comment of at most 65535 bytes.
  const std::int64_t tail_size = std::min<std::int64_t>(size_, kEndSize + 65535);
  const std::string tail = ReadAt(size_ - tail_size, tail_size, "end record");
  std::int64_t end = -1;
  for (std::int64_t k = tail_size - kEndSize; k >= 0; --k) {
    if (U32(tail, k) == kEndSignature) {
      end = k;
      break;
    }
  }
  if (end < 0) ThrowInputError(name_, "", "a zip archive (no end-of-central-directory record)");
  const std::uint16_t disk = U16(tail, end + 4), cd_disk = U16(tail, end + 6);
  const std::uint16_t disk_entries = U16(tail, end + 8), entries = U16(tail, end + 10);
  const std::uint32_t cd_size = U32(tail, end + 12), cd_offset = U32(tail, end + 16);
  if (disk != 0 || cd_disk != 0 || disk_entries != entries) {
    ThrowInputError(name_, "end record", "a single-disk archive");
  }
  if (entries == 0xFFFF || cd_size == 0xFFFFFFFFu || cd_offset == 0xFFFFFFFFu) {
    ThrowInputError(name_, "end record", "a zip archive without zip64 records");
  }
  const std::int64_t end_offset = size_ - tail_size + end;
  if (std::int64_t(cd_offset) + cd_size > end_offset) {
    ThrowInputError(name_, "central directory", "a directory that ends before the end record");
  }
  if (entries > limits_.max_entries) {
    ThrowInputError(name_, "central directory", "at most " + std::to_string(limits_.max_entries) + " entries");
  }
  const std::string cd = ReadAt(cd_offset, cd_size, "central directory");
  size_t at = 0;
  std::int64_t total = 0;
  for (int e = 0; e < entries; ++e) {
    const std::string field = "central directory entry " + std::to_string(e);
    if (at + kCentralSize > cd.size() || U32(cd, at) != kCentralSignature) {
      ThrowInputError(name_, field, "a central directory record (truncated or corrupt)");
    }
    ZipEntry z;
    const std::uint16_t flags = U16(cd, at + 8);
    z.method = U16(cd, at + 10);
    z.crc32 = U32(cd, at + 16);
    z.compressed = U32(cd, at + 20);
    z.uncompressed = U32(cd, at + 24);
    const size_t name_len = U16(cd, at + 28), extra_len = U16(cd, at + 30), comment_len = U16(cd, at + 32);
    z.header_offset = U32(cd, at + 42);
    if (at + kCentralSize + name_len + extra_len + comment_len > cd.size()) {
      ThrowInputError(name_, field, "a record within the central directory");
    }
    z.name = cd.substr(at + kCentralSize, name_len);
    at += kCentralSize + name_len + extra_len + comment_len;
    const std::string entry_field = "entry \"" + z.name.substr(0, 80) + "\"";
    if (const std::string p = NameProblem(z.name); !p.empty()) ThrowInputError(name_, entry_field, p);
    if (flags & 1) ThrowInputError(name_, entry_field, "an unencrypted entry");
    if (z.method != 0 && z.method != 8) {
      ThrowInputError(name_, entry_field,
                      "a stored or deflated entry (compression method " + std::to_string(z.method) + ")");
    }
    if (z.method == 0 && z.compressed != z.uncompressed) {
      ThrowInputError(name_, entry_field, "a stored entry whose sizes agree");
    }
    if (z.uncompressed > limits_.max_entry_bytes) {
      ThrowInputError(name_, entry_field,
                      "at most " + std::to_string(limits_.max_entry_bytes) + " bytes uncompressed (declares " +
                          std::to_string(z.uncompressed) + ")");
    }
    total += z.uncompressed;
    if (total > limits_.max_total_bytes) {
      ThrowInputError(name_, "central directory",
                      "at most " + std::to_string(limits_.max_total_bytes) + " bytes uncompressed in all");
    }
    if (z.header_offset + kLocalSize > cd_offset) {
      ThrowInputError(name_, entry_field, "a local header before the central directory");
    }
    if (index_.count(z.name)) ThrowInputError(name_, entry_field, "one entry of that name");
    index_[z.name] = entries_.size();
    entries_.push_back(z);
  }
}

bool ZipReader::Has(const std::string& entry) const {
  return index_.count(entry) > 0 && (entry.empty() || entry.back() != '/');
}

std::string ZipReader::Read(const std::string& entry) const {
  const auto it = index_.find(entry);
  const std::string field = "entry \"" + entry.substr(0, 80) + "\"";
  if (it == index_.end()) ThrowInputError(name_, field, "an entry of that name");
  const ZipEntry& z = entries_[it->second];
  const std::string local = ReadAt(z.header_offset, kLocalSize, field);
  if (U32(local, 0) != kLocalSignature) ThrowInputError(name_, field, "a local file header");
  const std::int64_t data = z.header_offset + kLocalSize + U16(local, 26) + U16(local, 28);
  const std::string packed = ReadAt(data, z.compressed, field);
  std::string out;
  if (z.method == 0) {
    out = packed;
  } else {
    // Inflate into exactly the declared size; more output than that is a lie about the size.
    out.assign(static_cast<size_t>(z.uncompressed), '\0');
    z_stream s;
    std::memset(&s, 0, sizeof(s));
    if (inflateInit2(&s, -MAX_WBITS) != Z_OK) throw std::runtime_error("zlib: inflateInit2 failed");
    s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(packed.data()));
    s.avail_in = static_cast<uInt>(packed.size());
    s.next_out = reinterpret_cast<Bytef*>(out.data());
    s.avail_out = static_cast<uInt>(out.size());
    int rc = inflate(&s, Z_FINISH);
    // A stream that fills the buffer exactly may still need a call to see its end marker.
    if (rc == Z_BUF_ERROR && s.avail_out == 0) {
      unsigned char probe;
      s.next_out = &probe;
      s.avail_out = 1;
      rc = inflate(&s, Z_FINISH);
      if (s.avail_out == 0) rc = Z_BUF_ERROR;
    }
    const std::int64_t produced = static_cast<std::int64_t>(s.total_out);
    inflateEnd(&s);
    if (rc != Z_STREAM_END || produced != z.uncompressed) {
      ThrowInputError(name_, field,
                      "deflated data of its declared " + std::to_string(z.uncompressed) +
                          " bytes (corrupt, truncated, or inflating past its size)");
    }
  }
  const auto crc = static_cast<std::uint32_t>(
      ::crc32(0L, reinterpret_cast<const Bytef*>(out.data()), static_cast<uInt>(out.size())));
  if (crc != z.crc32) ThrowInputError(name_, field, "data matching its CRC-32");
  return out;
}

std::string ResolveArchivePath(const std::string& base, const std::string& relative) {
  std::string rel = relative;
  for (char& c : rel) {
    if (c == '\\') c = '/';
  }
  if (rel.empty() || rel[0] == '/' || (rel.size() >= 2 && rel[1] == ':') || rel.find('\0') != std::string::npos) {
    return "";
  }
  std::vector<std::string> parts;
  std::stringstream b(base + rel);
  for (std::string part; std::getline(b, part, '/');) {
    if (part.empty() || part == ".") continue;
    if (part == "..") {
      if (parts.empty()) return "";
      parts.pop_back();
    } else {
      parts.push_back(part);
    }
  }
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : "/") + p;
  return out;
}

}  // namespace nerfreg
