#include "nerfreg/data/convert.h"

#include <filesystem>

#include "nerfreg/data/colmap.h"
#include "nerfreg/data/llff.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

namespace fs = std::filesystem;

namespace nerfreg {

void ConvertOptions::Check() const {
  if (to != "nerf" && to != "nerfstudio" && to != "llff" && to != "colmap") {
    ThrowInputError("--to", "", "nerf, nerfstudio, llff or colmap, got '" + to + "'");
  }
}

CameraFormat DetectCameraFormat(const std::string& input) {
  if (FileExists(input)) {
    const std::string name = fs::path(input).filename().string();
    if (LowerExtension(input) == ".json") return CameraFormat::kTransformsJson;
    if (name == "poses_bounds.npy") return CameraFormat::kLlff;
  } else if (DirExists(input)) {
    if (IsColmapModelDir(input)) return CameraFormat::kColmap;
    if (FileExists(JoinPaths(input, "poses_bounds.npy"))) return CameraFormat::kLlff;
    if (FileExists(JoinPaths(input, "transforms.json"))) return CameraFormat::kTransformsJson;
  }
  ThrowInputError(input, "", "a transforms.json, an LLFF poses_bounds.npy or a COLMAP model folder");
}

Dataset ReadCameras(const std::string& input) {
  switch (DetectCameraFormat(input)) {
    case CameraFormat::kTransformsJson:
      return ReadTransformsJson(DirExists(input) ? JoinPaths(input, "transforms.json") : input);
    case CameraFormat::kLlff:
      return ReadLlff(DirExists(input) ? input : fs::path(input).parent_path().string());
    case CameraFormat::kColmap: {
      // COLMAP's usual layout is PROJECT/sparse/0 with images in PROJECT/images.
      const fs::path dir = fs::absolute(input);
      std::string image_root = (dir.parent_path().parent_path() / "images").string();
      if (!DirExists(image_root)) image_root = dir.string();
      Dataset d = DatasetFromColmap(ReadColmapModel(input), image_root);
      d.Check(input);  // intrinsics (a negative focal length) and magnitudes, as for the other formats
      return d;
    }
  }
  throw std::logic_error("ReadCameras: unreachable");
}

void WriteNerfstudio(const Dataset& dataset, const std::string& path, bool force) {
  if (dataset.trained_from_data) {
    // Beside the file, where ReadTransformsJson looks for it; written first so a refused
    // overwrite leaves no transforms.json without it.
    const std::string dataparser = JoinPaths(ParentDir(path), "dataparser_transforms.json");
    CheckCanWriteOutput(dataparser, force);
    WriteDataparserTransforms(*dataset.trained_from_data, dataparser);
  }
  WriteTransformsJson(dataset, path, TransformsJsonFlavour::kNerfstudio);
}

void WriteCameras(const Dataset& dataset, const std::string& out, const ConvertOptions& options) {
  options.Check();
  Dataset d = dataset;
  std::string out_dir = out;
  const bool json_out = options.to == "nerf" || options.to == "nerfstudio";
  if (json_out && LowerExtension(out) == ".json") out_dir = fs::path(out).parent_path().string();
  if (out_dir.empty()) out_dir = ".";
  // Keep every image reachable from the new location.
  for (auto& f : d.frames) {
    const fs::path abs = fs::absolute(dataset.ImagePath(f));
    f.file_path = fs::relative(abs, fs::absolute(out_dir)).string();
  }
  d.root = out_dir;
  if (json_out) {
    const std::string path = LowerExtension(out) == ".json" ? out : JoinPaths(out, "transforms.json");
    CheckCanWriteOutput(path, options.force);
    if (options.to == "nerf") {
      WriteTransformsJson(d, path);
    } else {
      WriteNerfstudio(d, path, options.force);
    }
  } else if (options.to == "llff") {
    CheckCanWriteOutput(JoinPaths(out, "poses_bounds.npy"), options.force);
    WriteLlffPoses(d, out);
    LOG_INFO("{}: frames written in sorted-name order; LLFF expects the images in {}/images", out, out);
  } else {
    const std::string probe = JoinPaths(out, options.binary ? "cameras.bin" : "cameras.txt");
    CheckCanWriteOutput(probe, options.force);
    const ColmapModel model = ColmapFromDataset(d);
    if (options.binary)
      WriteColmapBinary(model, out);
    else
      WriteColmapText(model, out);
  }
}

}  // namespace nerfreg
