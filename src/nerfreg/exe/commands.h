#pragma once
// Every subcommand's entry point. Each layer's commands live in exe/<layer>_commands.cc.
// To add a command: declare it here and add a row to NERFREG_COMMAND_TABLE.

namespace nerfreg {
// Sets torch's intra-op thread count from the hardware (Debian's LibTorch defaults to 1).
void InitThreads();
}  // namespace nerfreg

// data / render (exe/data_commands.cc)
int RunRender(int argc, char** argv);
int RunConvert(int argc, char** argv);
// NeRF blocks (exe/nerf_commands.cc)
// Registration (exe/reg_commands.cc)
// DBARF (exe/dbarf_commands.cc)
// Reports (exe/report_command.cc)
int RunReport(int argc, char** argv);

#define NERFREG_COMMAND_TABLE                                                            \
  {"render", RunRender, "Render a mesh or procedural object into a dataset (and blocks)"}, \
  {"convert", RunConvert, "Convert camera files: transforms.json, LLFF, COLMAP"}, \
  {"report", RunReport, "Write one self-contained HTML page for a run directory"},
