#pragma once
// The project's torch-archive files (NeRF checkpoints, registration grids, DReg-NeRF weights,
// generalizable-NeRF checkpoints) all start with a "meta" entry: a JSON string holding a format
// tag and a version, so a file of another kind or version is refused with one clear line.
// Header-only and included by the LibTorch layers alone: the util library itself stays
// torch-free (the sanitizer build).
#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <sstream>
#include <string>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// A string as a uint8 [N] tensor and back (archives hold tensors, not strings).
inline torch::Tensor StringTensor(const std::string& s) {
  return torch::from_blob(const_cast<char*>(s.data()), {static_cast<std::int64_t>(s.size())}, torch::kUInt8).clone();
}
inline std::string TensorString(const torch::Tensor& t) {
  const torch::Tensor c = t.contiguous().to(torch::kUInt8);
  return std::string(reinterpret_cast<const char*>(c.data_ptr<std::uint8_t>()), c.numel());
}

// CRC-32 (zip's polynomial) of n bytes.
inline std::uint32_t Crc32(const char* data, size_t n) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) c = table[(c ^ static_cast<std::uint8_t>(data[i])) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

// What is wrong with the zip container of a torch archive, or "" when every stored entry is where
// the central directory says, under the same name, and matches its CRC-32, and the archive has the
// layout LibTorch's reader expects (every entry in one top folder, a "<folder>/version" record).
// Found by fuzz/torch_archive_fuzz.cc:
//  - LibTorch's reader skips the CRC check, so a flipped length inside the pickle reached its
//    unpickler, which reserved 4 GB for it; checking the CRCs first refuses every corrupted byte;
//  - its reader leaks its zip state when it throws while opening the archive (LibTorch 1.13), as
//    it does when the version record is missing (a changed byte in that entry's central-directory
//    name); so the layout is checked here, before LibTorch opens the file.
// Zip64 and compressed entries (torch writes neither for our files) are left to LibTorch.
inline std::string ZipArchiveProblem(const std::string& b) {
  auto u16 = [&](size_t o) { return std::uint32_t(std::uint8_t(b[o])) | std::uint32_t(std::uint8_t(b[o + 1])) << 8; };
  auto u32 = [&](size_t o) { return u16(o) | u16(o + 2) << 16; };
  if (b.size() < 22) return "no zip end record";
  size_t eocd = std::string::npos;
  for (size_t i = b.size() - 22;; --i) {
    if (u32(i) == 0x06054b50u) {
      eocd = i;
      break;
    }
    if (i == 0 || b.size() - i > 22 + 65535) break;
  }
  if (eocd == std::string::npos) return "no zip end record";
  const std::uint32_t entries = u16(eocd + 10), cd_size = u32(eocd + 12), cd_offset = u32(eocd + 16);
  if (entries == 0xFFFF || cd_offset == 0xFFFFFFFFu) return "";  // zip64
  if (std::uint64_t(cd_offset) + cd_size > eocd) return "zip central directory out of range";
  if (entries == 0) return "an empty zip archive";
  size_t p = cd_offset;
  std::string folder;  // the first entry's top folder, with its slash
  bool has_version = false;
  for (std::uint32_t e = 0; e < entries; ++e) {
    if (p + 46 > eocd || u32(p) != 0x02014b50u)
      return "zip central directory entry " + std::to_string(e) + " unreadable";
    const std::uint32_t method = u16(p + 10), crc = u32(p + 16), size = u32(p + 20), local = u32(p + 42);
    const size_t next = p + 46 + u16(p + 28) + u16(p + 30) + u16(p + 32);
    const std::string name = b.substr(p + 46, std::min<size_t>(u16(p + 28), eocd - p - 46));
    if (e == 0) {
      const size_t slash = name.find('/');
      if (slash == std::string::npos) return "zip entry " + name + " is not in a folder";
      folder = name.substr(0, slash + 1);
    }
    if (name.compare(0, folder.size(), folder) != 0)
      return "zip entry " + name + " is outside the archive's folder " + folder;
    has_version = has_version || name == folder + "version";
    if (size == 0xFFFFFFFFu || local == 0xFFFFFFFFu || method != 0) {
      p = next;
      continue;
    }
    if (std::uint64_t(local) + 30 > b.size() || u32(local) != 0x04034b50u)
      return "zip entry " + name + " has no local header";
    if (std::uint64_t(local) + 30 + u16(local + 26) > b.size() || b.compare(local + 30, u16(local + 26), name) != 0) {
      return "zip entry " + name + " has another name in its local header";
    }
    const std::uint64_t data = std::uint64_t(local) + 30 + u16(local + 26) + u16(local + 28);
    if (data + size > b.size()) return "zip entry " + name + " runs past the end";
    if (Crc32(b.data() + data, size) != crc) return "zip entry " + name + " fails its CRC-32";
    p = next;
  }
  if (!has_version) return "no " + folder + "version record";
  return "";
}

// Saves `archive` to `path` through memory and WriteFileAtomic. LibTorch's own file writer fails a
// short write by throwing from a destructor, which terminates the process (exit 134, temporary
// file left) on a full disk; in memory nothing can fail, and the file write is checked.
inline void SaveArchiveAtomic(torch::serialize::OutputArchive& archive, const std::string& path) {
  std::ostringstream stream;
  archive.save_to(stream);
  WriteFileAtomic(path, stream.str());
}

// Loads `path` into `archive` and returns its meta JSON after checking the format tag and the
// version. `what` names the kind of file in errors ("NeRF checkpoint"). Throws InputError naming
// the file when it is missing, unreadable or truncated, of another format, or of another version.
inline Json LoadArchiveMeta(const std::string& path, const std::string& what, const std::string& format_tag,
                            int version, torch::serialize::InputArchive* archive) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing " + what);
  const std::string problem = ZipArchiveProblem(ReadFileToString(path, std::int64_t(1) << 40));
  if (!problem.empty()) ThrowInputError(path, "", "a nerfreg " + what + " (unreadable or truncated: " + problem + ")");
  Json meta;
  try {
    archive->load_from(path, torch::Device(torch::kCPU));  // written on any device, read on the CPU
    torch::Tensor meta_tensor;
    archive->read("meta", meta_tensor);
    meta = Json::parse(TensorString(meta_tensor));
  } catch (const std::exception&) {
    ThrowInputError(path, "", "a nerfreg " + what + " (unreadable or truncated)");
  }
  const JsonField m(meta, path);
  if (!meta.is_object() || m.StringOr("format", "") != format_tag)
    ThrowInputError(path, "format", "\"" + format_tag + "\"");
  if (m["version"].Int() != version) {
    ThrowInputError(path, "version", std::to_string(version) + " (written by another nerfreg version)");
  }
  return meta;
}

// Refuses stored options that imply more parameters than the file can hold, before a model is
// built from them: a corrupt or hostile size would otherwise allocate many GB (found by
// fuzz/torch_archive_fuzz.cc). `min_parameters` is a lower bound on the parameters the options
// imply (the dominant weight matrices); each is stored as at least 2 bytes (float16 or wider).
inline void CheckArchiveCanHold(const std::string& path, const std::string& field, double min_parameters) {
  std::error_code ec;
  const double bytes = static_cast<double>(std::filesystem::file_size(path, ec));
  if (ec) ThrowInputError(path, "", "a readable file");
  if (!(min_parameters >= 0) || 2 * min_parameters > bytes) {
    ThrowInputError(path, field,
                    "sizes whose parameters fit in the file (they imply at least " + std::to_string(min_parameters) +
                        " parameters; the file has " + std::to_string(static_cast<std::int64_t>(bytes)) + " bytes)");
  }
}

}  // namespace nerfreg
