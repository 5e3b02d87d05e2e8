#pragma once
// Reading and writing camera files in any supported format, for `nerfreg convert` and for every
// command that takes "a dataset": a transforms.json file (or a folder holding one), an LLFF scene
// (poses_bounds.npy or its folder), or a COLMAP sparse model folder (text or binary).
#include <string>

#include "nerfreg/data/dataset.h"

namespace nerfreg {

enum class CameraFormat { kTransformsJson, kLlff, kColmap };

// Throws InputError when `input` is none of the formats.
CameraFormat DetectCameraFormat(const std::string& input);
Dataset ReadCameras(const std::string& input);

struct ConvertOptions {
  std::string to;       // "nerf", "nerfstudio", "llff" or "colmap"
  bool binary = false;  // COLMAP output as .bin (default .txt)
  bool force = false;   // overwrite existing outputs
  void Check() const;   // throws InputError naming the option
};

// nerfstudio's layout: transforms.json at `path` (camera_model, applied_transform, split lists) and,
// when the dataset has one, dataparser_transforms.json beside it. Image paths are written as they
// are. `force` overwrites an existing dataparser_transforms.json.
void WriteNerfstudio(const Dataset& dataset, const std::string& path, bool force);

// Writes `dataset` as options.to at `out` (a transforms.json path or a folder for nerf and
// nerfstudio; a folder for llff and colmap). Image paths are rewritten relative to the output location.
void WriteCameras(const Dataset& dataset, const std::string& out, const ConvertOptions& options);

}  // namespace nerfreg
