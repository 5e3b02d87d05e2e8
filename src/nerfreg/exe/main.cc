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

// Threading environment: torch's OpenMP threads spinning after each parallel region while
// OpenBLAS runs its own threads made a field forward+backward several times slower than passive
// OpenMP waiting with single-threaded OpenBLAS calls (torch parallelises around them); measured in
// docs/threads.md. libgomp and OpenBLAS read both variables in their own initialisers, before
// main, so a process started without them runs itself again with them set. This runs from the
// executable's .preinit_array: after the libraries are loaded but before any of them is
// initialised (the ELF rule glibc follows), so the first start costs the loading alone, not
// the libraries' initialisation (~0.45 s, most of it LibTorch's; done in main(), as until
// 2026-11-29, it was paid twice). libc's `environ` is not set up yet here, hence envp.
void EnsureThreadingEnvironment(int /*argc*/, char** argv, char** envp) {
  if (envp == nullptr || argv == nullptr) return;
  bool wait = false, blas = false, again = false;
  int count = 0;
  for (char** e = envp; *e != nullptr; ++e, ++count) {
    wait = wait || std::strncmp(*e, "OMP_WAIT_POLICY=", 16) == 0;
    blas = blas || std::strncmp(*e, "OPENBLAS_NUM_THREADS=", 21) == 0;
    again = again || std::strncmp(*e, "NERFREG_ENV_SET=", 16) == 0;
  }
  // Already set (by the user or a script), or this is the second start: nothing to change.
  if (again || (wait && blas)) return;
  static char wait_policy[] = "OMP_WAIT_POLICY=PASSIVE", blas_threads[] = "OPENBLAS_NUM_THREADS=1",
              marker[] = "NERFREG_ENV_SET=1";
  char** env = static_cast<char**>(std::malloc((count + 4) * sizeof(char*)));
  if (env == nullptr) return;
  int n = 0;
  for (int k = 0; k < count; ++k) env[n++] = envp[k];
  if (!wait) env[n++] = wait_policy;
  if (!blas) env[n++] = blas_threads;
  env[n++] = marker;
  env[n] = nullptr;
  execve("/proc/self/exe", argv, env);  // returns only on failure: then carry on as we are
  std::free(env);
}
__attribute__((section(".preinit_array"),
               used)) void (*ensure_threading_environment)(int, char**, char**) = &EnsureThreadingEnvironment;

}  // namespace

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
