// Commands of the data and render layers: render, convert.
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/util/error.h"

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
  DescribeCommand(app, "Convert camera files.", "nerfreg convert scene/transforms.json --to colmap --out scene/sparse/0");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  throw InputError("convert: not implemented yet");
}
