// Commands of the NeRF-block layer: nerf train | render | eval | export | import.
#include <filesystem>
#include <fstream>
#include <optional>

#include "nerfreg/data/convert.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/nerf/mesh_export.h"
#include "nerfreg/nerf/ngp_import.h"
#include "nerfreg/nerf/splat_export.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

int RunNerfTrain(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Train a NeRF block (instant-NGP-style field, fused CPU kernels) on a posed dataset: a transforms.json "
      "(or its folder), an LLFF scene or a COLMAP model. Writes BLOCK.ckpt, BLOCK.ckpt.json "
      "{psnr_test, seconds, iters} and the curves in BLOCK.ckpt.log.jsonl.",
      "nerfreg nerf train data/spider/block_0 --out runs/spider/block_0.ckpt --preset fast");
  std::string dataset_path, out, preset = "fast";
  int iters = 0, stop_after = 0, checkpoint_every = -1;
  std::int64_t samples = 0;
  unsigned seed = 0;
  bool resume = false;
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  app.add_option("dataset", dataset_path, "Dataset: transforms.json, its folder, an LLFF scene or a COLMAP model")
      ->required();
  app.add_option("--out", out, "Checkpoint to write")->required();
  app.add_option("--preset", preset, "fast (2 CPU cores) or default (the paper's settings)");
  app.add_option("--iters", iters, "Training iterations (default: the preset's)");
  app.add_option("--seed", seed, "Random seed");
  app.add_option("--stop-after", stop_after, "Checkpoint and stop at this step (continue later with --resume)");
  app.add_option("--checkpoint-every", checkpoint_every, "Checkpoint every n steps (default: the preset's)");
  app.add_option("--samples", samples, "Target samples per batch (default: the preset's)");
  app.add_flag("--resume", resume, "Continue the run in --out from its last checkpoint");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (app.count("--iters") && iters < 1)
    ThrowInputError("--iters", "", "at least 1 iteration, got " + std::to_string(iters));
  if (app.count("--stop-after") && stop_after < 1)
    ThrowInputError("--stop-after", "", "a step >= 1, got " + std::to_string(stop_after));
  if (app.count("--checkpoint-every") && checkpoint_every < 0) ThrowInputError("--checkpoint-every", "", ">= 0");
  if (app.count("--samples") && samples < 1) ThrowInputError("--samples", "", ">= 1");
  NerfTrainOptions options = NerfTrainOptions::Preset(preset);
  options.device = ParseDevice(device);
  if (iters > 0) options.iterations = iters;
  options.seed = seed;
  options.stop_after = stop_after;
  if (checkpoint_every >= 0) options.checkpoint_every = checkpoint_every;
  if (samples > 0) options.target_samples = samples;
  const Dataset dataset = ReadCameras(dataset_path);
  const std::vector<std::string> inputs = DatasetInputs(dataset_path, dataset);
  if (resume) {
    if (!FileExists(out))
      ThrowInputError(out, "", "an existing checkpoint to resume (drop --resume to start a new run)");
    CheckCanWriteOutput(out, /*force=*/true, inputs);  // writable, and not an input
  } else {
    CheckCanWriteOutput(out, common.force, inputs);
  }
  CheckCanWriteOutput(out + ".json", /*force=*/true, inputs);
  CheckImagesMatchCameras(dataset);
  const NerfTrainResult r = TrainNerfBlock(dataset, options, out, resume);
  if (r.iterations == options.iterations) {
    WriteJsonFile(
        out + ".json",
        {{"psnr_test", r.psnr_test}, {"seconds", r.seconds}, {"iters", r.iterations}, {"options", options.ToJson()}});
  }
  std::printf("{\"psnr_test\": %.3f, \"seconds\": %.1f, \"iters\": %d}\n", r.psnr_test, r.seconds, r.iterations);
  return 0;
}

int RunNerfRender(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app, "Render one PNG per frame of a transforms.json with a trained block (named as the frame's image).",
      "nerfreg nerf render runs/block_0.ckpt --transforms data/spider/block_0/transforms.json --out renders");
  std::string ckpt, transforms, out, device = "cpu";
  AddDeviceOption(app, &device);
  app.add_option("checkpoint", ckpt, "NeRF block checkpoint")->required();
  app.add_option("--transforms", transforms, "transforms.json with the cameras to render")->required();
  app.add_option("--out", out, "Output folder")->required();
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const torch::Device dev = ParseDevice(device);
  CheckCanWriteOutput(out, common.force, {ckpt, transforms});
  NerfBlock block = LoadNerfBlock(ckpt, nullptr, dev);
  const Dataset cams = ReadCameras(transforms);
  // Rendered into a temporary folder moved into place whole: a killed run leaves no partial set of
  // PNGs under the real name (which a rerun would then refuse as existing).
  OutputDir output(out, common.force, {ckpt, transforms});
  ProgressBar bar("nerf render", static_cast<std::int64_t>(cams.frames.size()), "view");
  for (const auto& f : cams.frames) {
    WriteImage(output.Path(std::filesystem::path(f.name).replace_extension(".png").string()),
               RenderImage(block, f.camera, f.cam_from_world));
    bar.Tick();
  }
  bar.Finish();
  output.Commit();
  return 0;
}

int RunNerfEval(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app, "PSNR and SSIM of a block's renders of a dataset's test views (white background).",
                  "nerfreg nerf eval runs/block_0.ckpt data/spider/block_0");
  std::string ckpt, dataset_path, out, device = "cpu";
  AddDeviceOption(app, &device);
  app.add_option("checkpoint", ckpt, "NeRF block checkpoint")->required();
  app.add_option("dataset", dataset_path, "Dataset whose test split is evaluated")->required();
  app.add_option("--out", out, "Also write the result to this JSON file");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const torch::Device dev = ParseDevice(device);
  if (!out.empty()) CheckCanWriteOutput(out, common.force, {ckpt, dataset_path});
  NerfBlock block = LoadNerfBlock(ckpt, nullptr, dev);
  const Dataset dataset = ReadCameras(dataset_path);
  if (dataset.IndicesOfSplit("test").empty())
    ThrowInputError(dataset_path, "frames", "at least one frame with \"split\": \"test\"");
  const NerfEvalResult r = EvaluateNerfBlock(block, dataset);
  const Json j = {{"psnr", r.psnr}, {"ssim", r.ssim}, {"views", r.views}};
  if (!out.empty()) WriteJsonFile(out, j);
  std::printf("%s\n", j.dump().c_str());
  return 0;
}

int RunNerfExport(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Export a block's occupied space as a coloured point cloud (--points), its density iso-surface as "
                  "a coloured triangle mesh (--mesh, marching cubes), or 3D Gaussian splats (--splats: one isotropic "
                  "Gaussian per occupied cell, the 3DGS PLY layout), all PLY.",
                  "nerfreg nerf export runs/block_0.ckpt --points block_0.ply");
  std::string ckpt, points, mesh_path, splats_path, device = "cpu";
  AddDeviceOption(app, &device);
  double threshold = -1;
  MeshExportOptions mesh_options;
  app.add_option("checkpoint", ckpt, "NeRF block checkpoint")->required();
  auto* points_opt = app.add_option("--points", points, "Output PLY point cloud");
  auto* mesh_opt = app.add_option("--mesh", mesh_path, "Output PLY triangle mesh (marching cubes on the density)");
  auto* splats_opt = app.add_option("--splats", splats_path, "Output 3D Gaussian splat PLY");
  points_opt->excludes(mesh_opt)->excludes(splats_opt);
  mesh_opt->excludes(splats_opt);
  app.add_option("--density", threshold, "Density threshold (default 5 for points, 2.5 for the mesh)");
  app.add_option("--resolution", mesh_options.resolution, "Mesh: marching-cubes cells per axis (default 128)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (points.empty() && mesh_path.empty() && splats_path.empty()) {
    throw InputError("nerf export: give --points OUT.ply, --mesh OUT.ply or --splats OUT.ply");
  }
  const torch::Device dev = ParseDevice(device);
  if (!splats_path.empty()) {
    const BlockSplatOptions so{threshold > 0 ? threshold : 5.0};
    so.Check();
    CheckCanWriteOutput(splats_path, common.force, {ckpt});
    NerfBlock block = LoadNerfBlock(ckpt, nullptr, dev);
    const Splats splats = BlockToSplats(block, so);
    WriteSplatPly(splats, splats_path);
    LOG_INFO("wrote {} splats to {}", splats.size(), splats_path);
    return 0;
  }
  if (!mesh_path.empty()) {
    if (threshold > 0) mesh_options.density_threshold = threshold;
    mesh_options.Check();
    CheckCanWriteOutput(mesh_path, common.force, {ckpt});
    NerfBlock block = LoadNerfBlock(ckpt, nullptr, dev);
    const ColoredMesh mesh = ExtractMesh(block, mesh_options);
    WriteMeshPly(mesh, mesh_path);
    LOG_INFO("wrote {} vertices, {} triangles to {}", mesh.vertices.size(0), mesh.triangles.size(0), mesh_path);
    return 0;
  }
  if (threshold <= 0) threshold = 5.0;
  CheckCanWriteOutput(points, common.force, {ckpt});
  NerfBlock block = LoadNerfBlock(ckpt, nullptr, dev);
  torch::NoGradGuard no_grad;
  // One jittered point per occupied cell above the density threshold, view-averaged colour.
  const BlockPoints exported = ExtractOccupiedPoints(block, threshold);
  const auto p = exported.xyz.contiguous(), c = exported.rgb.clamp(0, 1).contiguous();
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(p.size(0)) +
                    "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
                    "property uchar blue\nend_header\n";
  const float* pp = p.data_ptr<float>();
  const float* pc = c.data_ptr<float>();
  char line[128];
  for (std::int64_t i = 0; i < p.size(0); ++i) {
    std::snprintf(line, sizeof(line), "%.5f %.5f %.5f %d %d %d\n", pp[3 * i], pp[3 * i + 1], pp[3 * i + 2],
                  int(pc[3 * i] * 255 + 0.5f), int(pc[3 * i + 1] * 255 + 0.5f), int(pc[3 * i + 2] * 255 + 0.5f));
    ply += line;
  }
  WriteFileAtomic(points, ply);
  LOG_INFO("wrote {} points to {}", p.size(0), points);
  return 0;
}

int RunNerfImport(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Import an instant-ngp snapshot (.msgpack, or gzip/zlib-compressed .ingp) as a NeRF block: its hash grid "
      "and MLP weights (field flavor instant-ngp, same densities and colours), its density grid as the "
      "occupancy grid. The block lives in the frame of the transforms.json ngp trained on (ngp's "
      "scale/offset/axis cycle undone; --frame ngp keeps ngp's unit cube); --transforms adds that "
      "file's cameras to the block (needed by registration).",
      "nerfreg nerf import fox/base.ingp --transforms data/fox/transforms.json --out runs/fox.ckpt");
  std::string snapshot_path, out, transforms;
  NgpImportOptions options;
  app.add_option("snapshot", snapshot_path, "instant-ngp snapshot (.msgpack or .ingp)")->required();
  app.add_option("--out", out, "Checkpoint to write")->required();
  app.add_option("--transforms", transforms,
                 "The transforms.json the snapshot was trained on (cameras, scale, offset)");
  app.add_option("--frame", options.frame, "Block frame: nerf (the transforms.json frame, default) or ngp");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (options.frame != "nerf" && options.frame != "ngp") throw InputError("nerf import: --frame must be nerf or ngp");
  CheckCanWriteOutput(out, common.force, {snapshot_path, transforms});
  const NgpSnapshot snapshot = ReadNgpSnapshot(snapshot_path);
  std::optional<Dataset> cameras;
  if (!transforms.empty()) cameras = ReadCameras(transforms);
  NerfBlock block = SnapshotToNerfBlock(snapshot, snapshot_path, options, cameras ? &*cameras : nullptr);
  SaveNerfBlock(block, out);
  LOG_INFO("imported {} ({} levels x {} features, {} params, {:.1f}% occupied) to {}", snapshot_path,
           snapshot.encoding.levels, snapshot.encoding.features, snapshot.params.size(),
           100 * block.grid->OccupiedFraction(), out);
  return 0;
}
