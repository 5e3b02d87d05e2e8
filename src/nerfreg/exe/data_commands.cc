// Commands of the data and render layers: render, convert.
#include "nerfreg/data/convert.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"

using namespace nerfreg;

int RunRender(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app, "Render a mesh into a NeRF dataset.", "nerfreg render --mesh duck.gltf --blocks 2 --out data/duck");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  throw InputError("render: not implemented yet");
}

int RunConvert(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Convert cameras between transforms.json (NeRF-synthetic / instant-ngp), LLFF poses_bounds.npy and "
                  "COLMAP sparse models (text or binary). The input format is detected.",
                  "nerfreg convert scene/transforms.json --to colmap --out scene/sparse/0");
  std::string input, out;
  ConvertOptions options;
  app.add_option("input", input, "transforms.json, poses_bounds.npy (or its folder), or a COLMAP model folder")->required();
  app.add_option("--to", options.to, "Output format: nerf, llff or colmap")->required();
  app.add_option("--out", out, "Output: a transforms.json path or folder (nerf), a folder (llff, colmap)")->required();
  app.add_flag("--binary", options.binary, "COLMAP output as .bin instead of .txt");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  options.force = common.force;
  const Dataset dataset = ReadCameras(input);
  WriteCameras(dataset, out, options);
  LOG_INFO("converted {} frames from {} to {} at {}", dataset.frames.size(), input, options.to, out);
  return 0;
}
