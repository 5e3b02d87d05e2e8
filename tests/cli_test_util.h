#pragma once
// Runs the built nerfreg binary (and other programs) from end-to-end tests.
#include <string>

namespace nerfreg {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs `command` through /bin/sh, capturing stdout+stderr.
CommandResult RunShell(const std::string& command);

// Runs build/nerfreg with the given argument string.
CommandResult RunNerfreg(const std::string& args);

bool HaveProgram(const std::string& name);

}  // namespace nerfreg
