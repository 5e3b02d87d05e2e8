#include "cli_test_util.h"

#include <stdio.h>
#include <sys/wait.h>

#include <array>

namespace nerfreg {

CommandResult RunShell(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) result.output.append(buf.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return result;
}

CommandResult RunNerfreg(const std::string& args) { return RunShell(std::string(NERFREG_BINARY) + " " + args); }

bool HaveProgram(const std::string& name) { return RunShell("command -v " + name + " >/dev/null").exit_code == 0; }

}  // namespace nerfreg
