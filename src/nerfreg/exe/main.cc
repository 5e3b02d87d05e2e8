// nerfreg: one binary, a table of subcommands. Errors from user input are caught here once and
// printed as one line; the exit code tells their kind (2 bad input or usage, 3 internal error, 4 a lost process of a
// distributed job).
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "nerfreg/dist/launch.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

namespace {

struct CommandEntry {
  const char* name;  // one or two words
  int (*run)(int argc, char** argv);
  const char* summary;
};

// The contract is docs/cli.md; keep names stable.
const std::vector<CommandEntry>& Commands() {
  static const std::vector<CommandEntry> commands = {NERFREG_COMMAND_TABLE};
  return commands;
}

void PrintUsage() {
  std::printf(
      "nerfreg: register NeRF blocks and pose unposed images.\n\nUsage: nerfreg COMMAND [options]"
      " (COMMAND --help for details)\n\nCommands:\n");
  for (const auto& c : Commands()) std::printf("  %-22s %s\n", c.name, c.summary);
#if NERFREG_LEARNED_CORE_ONLY
  std::printf(
      "\nThis is the learned-core build (NERFREG_LEARNED_CORE_ONLY): rendering, block registration, cameras\n"
      "estimated from images (dbarf poses / eval; the dbarf commands here take --scene-cameras ground-truth or\n"
      "posed images) and reports need the full build, which links Embree, Open3D, Ceres and OpenCV (docs/gpu.md).\n");
#endif
}

}  // namespace

// Threading environment: torch's OpenMP threads spinning after each parallel region while
// OpenBLAS runs its own threads made a field forward+backward several times slower than passive
// OpenMP waiting with single-threaded OpenBLAS calls (torch parallelises around them); measured in
// docs/threads.md. libgomp and OpenBLAS read OMP_WAIT_POLICY and OPENBLAS_NUM_THREADS with getenv
// in their own initialisers, before main. The executable comes first in the loader's lookup scope,
// so this definition is the getenv every library calls: it answers from the environment as libc's
// does, and gives those two defaults where the environment lacks them (a user's own value wins).
// Until 2026-11-29 the process started itself again with the variables set (execve from
// .preinit_array), which loaded every library twice: ~0.2 s a start. Children other than nerfreg
// itself see the environment as it is.
extern "C" __attribute__((visibility("default"))) char* getenv(const char* name) noexcept {
  const size_t length = std::strlen(name);
  if (environ != nullptr) {
    for (char** e = environ; *e != nullptr; ++e) {
      if (std::strncmp(*e, name, length) == 0 && (*e)[length] == '=') return *e + length + 1;
    }
  }
  static char passive[] = "PASSIVE", one[] = "1";
  if (std::strcmp(name, "OMP_WAIT_POLICY") == 0) return passive;
  if (std::strcmp(name, "OPENBLAS_NUM_THREADS") == 0) return one;
  return nullptr;
}

int main(int argc, char** argv) {
  nerfreg::InstallOutputSignalHandlers();
  nerfreg::InitLogging(nerfreg::LogOptions{});
  nerfreg::InitThreads();
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    PrintUsage();
    return argc < 2 ? 2 : 0;
  }
  // Two-word commands first ("nerf train"), then one-word ones ("render").
  const CommandEntry* found = nullptr;
  int words = 0;
  for (const auto& c : Commands()) {
    const std::string name = c.name;
    if (argc >= 3 && name == std::string(argv[1]) + " " + argv[2]) {
      found = &c;
      words = 2;
      break;
    }
  }
  if (!found) {
    for (const auto& c : Commands()) {
      if (std::string(c.name) == argv[1]) {
        found = &c;
        words = 1;
        break;
      }
    }
  }
  if (!found) {
    std::fprintf(stderr, "nerfreg: unknown command '%s'\n\n", argv[1]);
    PrintUsage();
    return 2;
  }
  // Hand the subcommand an argv whose [0] is its full name, for its --help.
  std::vector<char*> sub_argv;
  std::string full_name = std::string("nerfreg ") + found->name;
  sub_argv.push_back(full_name.data());
  for (int i = 1 + words; i < argc; ++i) sub_argv.push_back(argv[i]);
  try {
    return found->run(static_cast<int>(sub_argv.size()), sub_argv.data());
  } catch (const nerfreg::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const nerfreg::DistError& e) {
    std::fprintf(stderr, "error: distributed: %s\n", e.what());
    return 4;
  } catch (const std::filesystem::filesystem_error& e) {
    // A failed copy or folder operation outside our checked writers: a full disk or a folder the
    // user cannot write is still the user's to fix, so it is reported as such.
    const int err = e.code().value();
    const std::string path = e.path1().empty() ? std::string("output") : e.path1().string();
    if (err == ENOSPC || err == EDQUOT || err == EFBIG) {
      std::fprintf(stderr, "error: %s: expected space to write (disk full?)\n", path.c_str());
      return 2;
    }
    if (err == EACCES || err == EROFS || err == EPERM) {
      std::fprintf(stderr, "error: %s: expected a writable location (%s)\n", path.c_str(), e.code().message().c_str());
      return 2;
    }
    std::fprintf(stderr, "internal error: %s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "internal error: %s\n", e.what());
    return 3;
  }
}
