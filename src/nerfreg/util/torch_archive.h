#pragma once
// The project's torch-archive files (NeRF checkpoints, registration grids, DReg-NeRF weights,
// generalizable-NeRF checkpoints) all start with a "meta" entry: a JSON string holding a format
// tag and a version, so a file of another kind or version is refused with one clear line.
// Header-only and included by the LibTorch layers alone: the util library itself stays
// torch-free (the sanitizer build).
#include <torch/torch.h>

#include <cstdint>
#include <filesystem>
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

// Loads `path` into `archive` and returns its meta JSON after checking the format tag and the
// version. `what` names the kind of file in errors ("NeRF checkpoint"). Throws InputError naming
// the file when it is missing, unreadable or truncated, of another format, or of another version.
inline Json LoadArchiveMeta(const std::string& path, const std::string& what, const std::string& format_tag, int version,
                            torch::serialize::InputArchive* archive) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing " + what);
  Json meta;
  try {
    archive->load_from(path);
    torch::Tensor meta_tensor;
    archive->read("meta", meta_tensor);
    meta = Json::parse(TensorString(meta_tensor));
  } catch (const std::exception&) {
    ThrowInputError(path, "", "a nerfreg " + what + " (unreadable or truncated)");
  }
  const JsonField m(meta, path);
  if (!meta.is_object() || m.StringOr("format", "") != format_tag) ThrowInputError(path, "format", "\"" + format_tag + "\"");
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
