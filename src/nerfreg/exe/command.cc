#include "nerfreg/exe/command.h"

#include <sstream>

#include "nerfreg/data/dataset.h"
#include "nerfreg/dist/launch.h"
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
  app.add_option("--device", *device,
                 "Where the networks run: cpu (default), cuda, cuda:N or auto (a GPU when present)");
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

void AddDistOptions(CLI::App& app, DistOptions* options) {
  app.add_option("--nproc", options->nproc,
                 "Data-parallel processes on this machine, each with its share of the cores and of each batch "
                 "(c10d: Gloo on the CPU, NCCL with --device cuda, worker r on cuda:r; default 1)");
  app.add_option("--nnodes", options->nnodes, "Machines in the job (default 1); run the command on each");
  app.add_option("--node-rank", options->node_rank, "This machine's index in [0, --nnodes)");
  app.add_option("--master-addr", options->master_addr, "Address of rank 0's machine (default 127.0.0.1)");
  app.add_option("--master-port", options->master_port,
                 "Rendezvous port (default 0: a free one; needed with --nnodes > 1)");
  app.add_option("--dist-timeout", options->timeout_s,
                 "Seconds a rank waits for the others before failing (default 120)");
}

int LaunchIfAsked(const DistOptions& options, int argc, char** argv) {
  options.Check();
  if (!ShouldLaunch(options)) return -1;
  // argv[0] is the full command name ("nerfreg reg train"): the workers get its words back.
  std::vector<std::string> args;
  std::istringstream words(argv[0]);
  for (std::string w; words >> w;) {
    if (w != "nerfreg") args.push_back(w);
  }
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  return LaunchWorkers(options, args);
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
