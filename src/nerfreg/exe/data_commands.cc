// Commands of the data and render layers: render, convert.
#include "nerfreg/data/convert.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

using namespace nerfreg;

namespace {

// --size W or WxH.
void ParseRenderSize(const std::string& size, RenderDatasetOptions* options) {
  if (size.empty()) return;
  const size_t x = size.find('x');
  try {
    options->width = std::stoi(size.substr(0, x));
    options->height = x == std::string::npos ? 0 : std::stoi(size.substr(x + 1));
  } catch (const std::exception&) {
    ThrowInputError("--size", "", "W or WxH, got " + size);
  }
  if (options->width <= 0 || (x != std::string::npos && options->height <= 0))
    ThrowInputError("--size", "", "positive W[xH]");
}

// --block-scale-range A,B (or A).
void ParseScaleRange(const std::string& range, BlockFrameOptions* frame) {
  if (range.empty()) return;
  const size_t comma = range.find(',');
  try {
    frame->min_scale = std::stod(range.substr(0, comma));
    frame->max_scale = comma == std::string::npos ? frame->min_scale : std::stod(range.substr(comma + 1));
  } catch (const std::exception&) {
    ThrowInputError("--block-scale-range", "", "A,B, got " + range);
  }
}

// The mesh to render: the file's (normalised; before a backdrop for the forward-facing kinds) or
// the procedural object / scene of the seed for the trajectory; sets the options' trajectory seed
// and the material's texture modulation.
TriangleMesh RenderMesh(const std::string& mesh_path, long procedural, const std::string& material,
                        RenderDatasetOptions* options) {
  TriangleMesh mesh;
  if (!mesh_path.empty()) {
    options->trajectory_seed = options->seed;
    mesh = LoadMesh(mesh_path);
    NormalizeMesh(&mesh, 2.5f);
    if (options->trajectory != "orbit") mesh = WithBackdrop(mesh);
    return mesh;
  }
  const unsigned seed = static_cast<unsigned>(procedural);
  const SceneMaterial scene_material = ParseSceneMaterial(material);
  options->trajectory_seed = seed;  // each scene its own path
  if (options->trajectory == "orbit") {
    mesh = ProceduralObject(seed);
  } else if (options->trajectory == "llff") {
    mesh = ProceduralLayeredScene(seed, scene_material);
  } else if (options->trajectory == "room") {
    mesh = ProceduralRoom(seed, scene_material);
  } else {
    mesh = ProceduralForwardScene(seed, 2.0f, scene_material);
  }
  options->render.texture_modulation = MaterialTextureModulation(scene_material);
  return mesh;
}

}  // namespace

int RunRender(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Render a mesh (OFF/PLY/OBJ/STL/glTF) or a procedural object/scene into a NeRF dataset: the "
                  "DReg-NeRF orbit, forward-facing look-at views or LLFF-like hand-held ones, optionally split into "
                  "blocks each in its own random frame with the ground truth in ground_truth.json.",
                  "nerfreg render --mesh /usr/share/assimp/models/OBJ/spider.obj --blocks 2 --out data/spider");
  std::string mesh_path, out, size;
  long procedural = -1;
  std::string scale_range;
  RenderDatasetOptions options;
  auto* mesh_opt = app.add_option("--mesh", mesh_path, "Mesh file (OFF, PLY, OBJ, STL, glTF, GLB)");
  auto* proc_opt =
      app.add_option("--procedural", procedural, "Seed of a procedural object (orbit) or scene (forward, llff, room)");
  mesh_opt->excludes(proc_opt);
  app.add_option("--trajectory", options.trajectory,
                 "orbit (objects), forward (look-at scenes), llff (hand-held, parallel axes, layered depth) or "
                 "room (a walk through a room)")
      ->check(CLI::IsMember({"orbit", "forward", "llff", "room"}));
  app.add_option("--views", options.views, "Number of views (default 120 orbit, 20 forward and llff, 30 room)");
  app.add_option("--size", size, "Image size W or WxH (default 100 orbit, 128x96 scenes)");
  app.add_option("--blocks", options.blocks, "Split the views into K blocks by k-means on camera centres");
  app.add_option("--block-rotation", options.block_frame.max_rotation_deg,
                 "Cap on each block's random rotation, degrees (default: unbounded)");
  app.add_option("--block-translation", options.block_frame.max_translation,
                 "Bound on each translation coordinate (default 0.2)");
  app.add_option("--block-scale-range", scale_range, "A,B: each block's Sim(3) scale drawn in [A, B] (default 1,1)");
  std::string material = "textured";
  app.add_option("--material", material,
                 "Procedural forward scenes: textured, low-texture or repetitive (default textured)");
  app.add_option("--spread", options.forward_spread,
                 "Forward: half-extent of the camera spiral (default 0.35); llff: of the hand-held path (0.25)");
  app.add_option("--test-every", options.test_every, "Every n-th view of a block is a test view (default 20)");
  app.add_option("--supersample", options.render.supersample, "Rays per pixel side (default 2)");
  app.add_flag("--depth", options.write_depth, "Also write z-depth maps as depth/r_XXX.npy");
  app.add_flag("--splats", options.write_splats,
               "Also write 3D Gaussian splats of the seen surface: splats.ply, block_k/splats.ply");
  std::vector<double> distortion;
  app.add_option("--distortion", distortion, "K1[,K2]: radial lens distortion of the cameras (OpenCV; default 0)")
      ->delimiter(',')
      ->expected(1, 2);
  app.add_option("--noise", options.noise_sigma,
                 "Gaussian pixel noise, standard deviation in [0, 1] units (default 0)");
  app.add_option("--jpeg", options.jpeg_quality, "Write JPEG images of this quality (1..100) instead of PNG");
  app.add_option("--seed", options.seed, "Seed of the block split and frames");
  app.add_option("--out", out, "Output dataset folder")->required();
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  options.force = common.force;
  if (!distortion.empty()) options.k1 = distortion[0], options.k2 = distortion.size() > 1 ? distortion[1] : 0.0;
  if (mesh_path.empty() && procedural < 0) throw InputError("render: give --mesh FILE or --procedural SEED");
  if (!mesh_path.empty() && options.trajectory == "room")
    ThrowInputError("--trajectory", "", "orbit, forward or llff with --mesh (room is procedural)");
  CheckCanWriteOutput(out, common.force, {mesh_path});
  ParseRenderSize(size, &options);
  ParseScaleRange(scale_range, &options.block_frame);
  const TriangleMesh mesh = RenderMesh(mesh_path, procedural, material, &options);
  const auto summary = RenderDataset(mesh, options, out);
  LOG_INFO("rendered {} views into {} block(s) at {} in {:.1f} s", summary.views, summary.blocks, out, summary.seconds);
  return 0;
}

int RunConvert(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Convert cameras between transforms.json (NeRF-synthetic / instant-ngp / nerfstudio), LLFF poses_bounds.npy and "
      "COLMAP sparse models (text or binary). The input format is detected.",
      "nerfreg convert scene/transforms.json --to colmap --out scene/sparse/0");
  std::string input, out;
  ConvertOptions options;
  app.add_option("input", input, "transforms.json, poses_bounds.npy (or its folder), or a COLMAP model folder")
      ->required();
  app.add_option("--to", options.to, "Output format: nerf, nerfstudio, llff or colmap")->required();
  app.add_option("--out", out, "Output: a transforms.json path or folder (nerf, nerfstudio), a folder (llff, colmap)")
      ->required();
  app.add_flag("--binary", options.binary, "COLMAP output as .bin instead of .txt");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  options.force = common.force;
  const Dataset dataset = ReadCameras(input);
  WriteCameras(dataset, out, options);
  LOG_INFO("converted {} frames from {} to {} at {}", dataset.frames.size(), input, options.to, out);
  return 0;
}
