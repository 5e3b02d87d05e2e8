#include "nerfreg/exe/command.h"

#include <cstdio>
#include <sstream>
#include <string>

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

namespace {

// What follows `prefix` in `text`, or "" when text does not start with it.
std::string After(const std::string& text, const std::string& prefix) {
  return text.rfind(prefix, 0) == 0 ? text.substr(prefix.size()) : "";
}

// By type, not by get_name(): CLI11 names some errors after the app rather than their class.
template <typename Error>
bool Is(const CLI::ParseError& e) {
  return dynamic_cast<const Error*>(&e) != nullptr;
}

}  // namespace

std::string CommandLineError(const CLI::ParseError& e) {
  const std::string what = e.what();
  const std::string help = " (--help lists them)";
  // "The following argument(s) was/were not expected: --bogus x"
  if (Is<CLI::ExtrasError>(e)) {
    const size_t colon = what.find(": ");
    return (colon == std::string::npos ? what : what.substr(colon + 2)) +
           ": expected an option or argument of this command" + help;
  }
  if (Is<CLI::RequiredError>(e)) {  // "--out is required", "checkpoint is required"
    const size_t required = what.find(" is required");
    if (required != std::string::npos) return what.substr(0, required) + ": expected a value: it is required" + help;
  }
  if (Is<CLI::ConversionError>(e)) {  // "Could not convert: --steps = abc"
    const std::string rest = After(what, "Could not convert: ");
    const size_t eq = rest.find(" = ");
    if (eq != std::string::npos) {
      return rest.substr(0, eq) + ": expected a value of its type, got " + rest.substr(eq + 3);
    }
  }
  if (Is<CLI::ArgumentMismatch>(e)) {  // "--steps: 1 required INT missing"
    const size_t colon = what.find(": "), required = what.find(" required "), missing = what.rfind(" missing");
    if (colon != std::string::npos && required != std::string::npos && missing != std::string::npos &&
        colon < required && required < missing) {
      return what.substr(0, colon) + ": expected " + what.substr(colon + 2, required - colon - 2) + " value(s) (" +
             what.substr(required + 10, missing - required - 10) + "), got none";
    }
  }
  // "--config: foo not in {cpu,paper}"
  const size_t colon = what.find(": ");
  if (colon != std::string::npos && what.find(' ') > colon) {
    return what.substr(0, colon) + ": expected a valid value: " + what.substr(colon + 2);
  }
  return "command line: expected valid arguments: " + what;
}

int ParseCommand(CLI::App& app, int argc, char** argv, const CommonOptions& common) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and the like: CLI11 prints them. Any other is bad input: one named line, exit 2, as
    // every other bad input gets, instead of CLI11's two lines without "error: ".
    if (e.get_exit_code() == 0) return app.exit(e);
    std::string line = CommandLineError(e);
    for (char& c : line)
      if (c == '\n') c = ' ';
    std::fprintf(stderr, "error: %s\n", line.c_str());
    return 2;
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
