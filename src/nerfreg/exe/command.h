#pragma once
// The nerfreg binary is one table of subcommands (see docs/cli.md). Each subcommand is a
// `int RunX(int argc, char** argv)` that parses its options with CLI11, checks them, and calls a
// typed, testable function in a library layer. argv[0] is the full command name ("nerf train").
#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace nerfreg {

// Options every subcommand takes.
struct CommonOptions {
  bool quiet = false;
  bool json = false;
  bool verbose = false;
  bool force = false;  // overwrite existing outputs
};

// Adds --quiet, --json, --verbose and --force to `app`.
void AddCommonOptions(CLI::App& app, CommonOptions* options);

// Adds --device (cpu, cuda, cuda:N or auto; default cpu) to `app`. The command parses the value
// once with ParseDevice (util/torch_device.h) right after ParseCommand.
void AddDeviceOption(CLI::App& app, std::string* device);

// Parses argv into app. Returns -1 when parsing succeeded and the command should run, otherwise
// the exit code to return (0 for --help; 2 for a usage error, printed as CommandLineError's one
// line after "error: "). Also applies the logging options.
int ParseCommand(CLI::App& app, int argc, char** argv, const CommonOptions& common);

// A CLI11 usage error as the one line every bad input gets: "ARGUMENT: expected ...", e.g.
// "--steps: expected a value of its type, got abc".
std::string CommandLineError(const CLI::ParseError& e);

struct Dataset;
struct DistOptions;

// Adds --nproc, --nnodes, --node-rank, --master-addr, --master-port and --dist-timeout (data-parallel
// training, docs/distributed.md).
void AddDistOptions(CLI::App& app, DistOptions* options);

// The command as typed asks for workers (--nproc > 1, and this is not one): starts them running
// the same command, waits, and returns the exit code. Otherwise -1: run here.
int LaunchIfAsked(const DistOptions& options, int argc, char** argv);

// The files a dataset was read from, for CheckCanWriteOutput: the path given, its camera file
// (transforms.json, poses_bounds.npy) and every image. An output may not replace any of them.
std::vector<std::string> DatasetInputs(const std::string& given_path, const Dataset& dataset);

// Sets the app's description followed by an example line, shown by --help.
void DescribeCommand(CLI::App& app, const std::string& summary, const std::string& example);

}  // namespace nerfreg
