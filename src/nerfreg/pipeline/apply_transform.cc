#include "nerfreg/pipeline/apply_transform.h"

#include <fmt/format.h>

#include <filesystem>

#include "nerfreg/data/colmap.h"
#include "nerfreg/data/convert.h"
#include "nerfreg/data/npy.h"
#include "nerfreg/data/sim3_apply.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/render/ply_transform.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"

namespace fs = std::filesystem;

namespace nerfreg {

std::string ApplyInputKindName(ApplyInputKind kind) {
  switch (kind) {
    case ApplyInputKind::kSplats:
      return "splats";
    case ApplyInputKind::kPly:
      return "ply";
    case ApplyInputKind::kTransformsJson:
      return "transforms.json";
    case ApplyInputKind::kColmap:
      return "colmap";
    case ApplyInputKind::kLlff:
      return "llff";
    case ApplyInputKind::kNerfBlock:
      return "nerf-block";
  }
  throw std::logic_error("ApplyInputKindName: unknown kind");
}

void ApplyTransformOptions::Check() const {
  if (transform.empty()) ThrowInputError("reg apply", "", "a transform file T.json");
  if (input.empty()) ThrowInputError("reg apply", "", "an input file");
  if (output.empty()) ThrowInputError("--out", "", "a path (got an empty one)");
}

Sim3d ReadTargetFromSource(const std::string& path) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing T.json (written by reg register)");
  const Json json = ReadJsonFile(path);
  const JsonField root(json, path);
  if (!json.is_object()) root.Fail("an object with \"target_from_source\"");
  const Eigen::Matrix4d m = root["target_from_source"].Matrix(4, 4);
  try {
    const Sim3d t = Sim3d::FromMatrix(m, 1e-5);
    if (m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) throw std::invalid_argument("last row not 0 0 0 1");
    if (!(t.scale >= kMinSim3Scale && t.scale <= kMaxSim3Scale)) {
      root["target_from_source"].Fail(
          fmt::format("a scale in [{:g}, {:g}], got {:g}", kMinSim3Scale, kMaxSim3Scale, t.scale));
    }
    return t;
  } catch (const std::invalid_argument& e) {
    root["target_from_source"].Fail(std::string("a similarity transform [sR | t; 0 0 0 1] (") + e.what() + ")");
  }
}

ApplyInputKind DetectApplyInput(const std::string& input) {
  if (!FileExists(input) && !DirExists(input)) ThrowInputError(input, "", "an existing file or folder to move");
  if (FileExists(input) && LowerExtension(input) == ".ply") {
    return IsSplatPly(input) ? ApplyInputKind::kSplats : ApplyInputKind::kPly;
  }
  // Any .npy is taken for LLFF poses (a moved one need not be named poses_bounds.npy); its shape is checked.
  if (FileExists(input) && LowerExtension(input) == ".npy") return ApplyInputKind::kLlff;
  if (FileExists(input) && LowerExtension(input) != ".json") return ApplyInputKind::kNerfBlock;
  switch (DetectCameraFormat(input)) {
    case CameraFormat::kTransformsJson:
      return ApplyInputKind::kTransformsJson;
    case CameraFormat::kLlff:
      return ApplyInputKind::kLlff;
    case CameraFormat::kColmap:
      return ApplyInputKind::kColmap;
  }
  throw std::logic_error("DetectApplyInput: unreachable");
}

namespace {

void RequireExtension(const std::string& output, const std::string& ext, const std::string& what) {
  if (LowerExtension(output) != ext) ThrowInputError("--out", "", "a " + ext + " path for " + what + ", got " + output);
}

// transforms.json, and nerfstudio's dataparser_transforms.json beside it when there is one.
void ApplyToTransformsJson(const ApplyTransformOptions& o, const Sim3d& t, ApplyTransformResult* r) {
  const std::string path = DirExists(o.input) ? JoinPaths(o.input, "transforms.json") : o.input;
  RequireExtension(o.output, ".json", "a transforms.json");
  const std::string dataparser_in = JoinPaths(ParentDir(path), "dataparser_transforms.json");
  const std::string dataparser_out = JoinPaths(ParentDir(o.output), "dataparser_transforms.json");
  const bool dataparser = FileExists(dataparser_in);
  const std::vector<std::string> inputs = {o.transform, o.input, path, dataparser_in};
  CheckCanWriteOutput(o.output, o.force, inputs);
  if (dataparser) CheckCanWriteOutput(dataparser_out, o.force, inputs);
  const Json moved = TransformTransformsJson(ReadJsonFile(path), t, path);
  Sim3d trained;
  if (dataparser) trained = TransformDataparser(ReadDataparserTransforms(dataparser_in), t);
  // Written first, as convert --to nerfstudio does: a refused transforms.json leaves no stray one.
  if (dataparser) {
    WriteDataparserTransforms(trained, dataparser_out);
    r->written.push_back(dataparser_out);
  }
  WriteJsonFile(o.output, moved);
  r->written.push_back(o.output);
  r->items = static_cast<std::int64_t>(moved["frames"].size());
}

void ApplyToColmap(const ApplyTransformOptions& o, const Sim3d& t, ApplyTransformResult* r) {
  const ColmapModel model = ReadColmapModel(o.input);
  const bool text = FileExists(JoinPaths(o.input, "cameras.txt"));
  OutputDir out(o.output, o.force, {o.transform, o.input});
  const ColmapModel moved = TransformColmapModel(model, t);
  if (text) {
    WriteColmapText(moved, out.tmp());
  } else {
    WriteColmapBinary(moved, out.tmp());
  }
  out.Commit();
  r->written.push_back(o.output);
  r->items = static_cast<std::int64_t>(moved.images.size());
}

}  // namespace

ApplyTransformResult ApplyTransformFile(const ApplyTransformOptions& o) {
  o.Check();
  ApplyTransformResult r;
  r.kind = DetectApplyInput(o.input);
  const Sim3d target_from_source = ReadTargetFromSource(o.transform);
  r.applied = o.inverse ? target_from_source.Inverse() : target_from_source;
  const Sim3d& t = r.applied;
  const std::vector<std::string> inputs = {o.transform, o.input};
  switch (r.kind) {
    case ApplyInputKind::kSplats: {
      RequireExtension(o.output, ".ply", "splats");
      CheckCanWriteOutput(o.output, o.force, inputs);
      const Splats moved = TransformSplats(ReadSplatPly(o.input), t);
      WriteSplatPly(moved, o.output);
      r.items = moved.size();
      break;
    }
    case ApplyInputKind::kPly:
      RequireExtension(o.output, ".ply", "a PLY");
      CheckCanWriteOutput(o.output, o.force, inputs);
      r.items = TransformPlyFile(o.input, o.output, t).vertices;
      break;
    case ApplyInputKind::kTransformsJson:
      ApplyToTransformsJson(o, t, &r);
      return r;
    case ApplyInputKind::kColmap:
      ApplyToColmap(o, t, &r);
      return r;
    case ApplyInputKind::kLlff: {
      const std::string path = DirExists(o.input) ? JoinPaths(o.input, "poses_bounds.npy") : o.input;
      RequireExtension(o.output, ".npy", "an LLFF poses_bounds.npy");
      CheckCanWriteOutput(o.output, o.force, {o.transform, o.input, path});
      const NpyArray moved = TransformLlffPoses(ReadNpy(path), t, path);
      WriteNpy(o.output, moved);
      r.items = moved.shape[0];
      break;
    }
    case ApplyInputKind::kNerfBlock: {
      CheckCanWriteOutput(o.output, o.force, inputs);
      NerfBlock block = LoadNerfBlock(o.input);
      MoveNerfBlock(&block, t);
      SaveNerfBlock(block, o.output);
      r.items = static_cast<std::int64_t>(block.cameras.frames.size());
      break;
    }
  }
  r.written.push_back(o.output);
  return r;
}

}  // namespace nerfreg
