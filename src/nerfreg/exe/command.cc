#include "nerfreg/exe/command.h"

#include "nerfreg/data/dataset.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

void AddCommonOptions(CLI::App& app, CommonOptions* options) {
  app.add_flag("--quiet,-q", options->quiet, "Only warnings and errors; no progress bars");
  app.add_flag("--json", options->json, "Machine-readable JSON lines on stderr");
  app.add_flag("--verbose,-v", options->verbose, "Debug messages");
  app.add_flag("--force", options->force, "Overwrite existing outputs");
}

void AddDeviceOption(CLI::App& app, std::string* device) {
  app.add_option("--device", *device, "Where the networks run: cpu (default), cuda, cuda:N or auto (a GPU when present)");
}

int ParseCommand(CLI::App& app, int argc, char** argv, const CommonOptions& common) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  LogOptions log;
  log.quiet = common.quiet;
  log.json = common.json;
  log.verbose = common.verbose;
  InitLogging(log);
  return -1;
}

std::vector<std::string> DatasetInputs(const std::string& given_path, const Dataset& dataset) {
  std::vector<std::string> inputs = {given_path};
  if (DirExists(given_path)) {
    for (const char* name : {"transforms.json", "poses_bounds.npy"}) inputs.push_back(JoinPaths(given_path, name));
  }
  for (const auto& f : dataset.frames) inputs.push_back(dataset.ImagePath(f));
  return inputs;
}

void DescribeCommand(CLI::App& app, const std::string& summary, const std::string& example) {
  app.description(summary + "\n\nExample:\n  " + example);
}

}  // namespace nerfreg
