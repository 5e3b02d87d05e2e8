#include "nerfreg/dist/launch.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"

extern char** environ;

namespace nerfreg {

void DistOptions::Check() const {
  if (nproc < 1 || nproc > 1024) ThrowInputError("--nproc", "", "a number of processes in [1, 1024]");
  if (nnodes < 1 || nnodes > 1024) ThrowInputError("--nnodes", "", "a number of machines in [1, 1024]");
  if (node_rank < 0 || node_rank >= nnodes) ThrowInputError("--node-rank", "", "an index in [0, --nnodes)");
  if (master_port < 0 || master_port > 65535) ThrowInputError("--master-port", "", "a TCP port in [0, 65535]");
  if (nnodes > 1 && master_port == 0)
    ThrowInputError("--master-port", "", "a port every machine knows (with --nnodes > 1)");
  if (master_addr.empty()) ThrowInputError("--master-addr", "", "a host name or address");
  if (!(timeout_s >= 1)) ThrowInputError("--dist-timeout", "", "seconds >= 1");
}

bool ShouldLaunch(const DistOptions& options) { return options.world_size() > 1 && std::getenv("RANK") == nullptr; }

std::vector<std::pair<std::string, std::string>> WorkerEnvironment(const DistOptions& options, int local_rank, int port,
                                                                   unsigned hardware_threads, bool omp_threads_set) {
  std::vector<std::pair<std::string, std::string>> env = {
      {"RANK", std::to_string(options.node_rank * options.nproc + local_rank)},
      {"WORLD_SIZE", std::to_string(options.world_size())},
      {"LOCAL_RANK", std::to_string(local_rank)},
      {"LOCAL_WORLD_SIZE", std::to_string(options.nproc)},
      {"MASTER_ADDR", options.master_addr},
      {"MASTER_PORT", std::to_string(port)}};
  // Each worker its share of the cores: N workers of all cores each would oversubscribe them.
  if (!omp_threads_set) {
    env.push_back({"OMP_NUM_THREADS", std::to_string(std::max(1u, hardware_threads / options.nproc))});
  }
  return env;
}

namespace {

// A port nothing listens on now (the store binds it a moment later; a clash is a named
// rendezvous error, not a hang).
int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw DistError("no socket for a free port (" + std::string(std::strerror(errno)) + ")");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    close(fd);
    throw DistError("no free TCP port on this machine (" + std::string(std::strerror(errno)) + ")");
  }
  close(fd);
  return ntohs(addr.sin_port);
}

struct Worker {
  pid_t pid = -1;
  int rank = 0;
  bool done = false, stopped = false;  // stopped: by the launcher, after another failed
  int status = 0;
};

std::string Describe(int status) {
  if (WIFSIGNALED(status)) {
    return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  }
  return "exited with code " + std::to_string(WEXITSTATUS(status));
}

bool Failed(int status) { return !WIFEXITED(status) || WEXITSTATUS(status) != 0; }

}  // namespace

int LaunchWorkers(const DistOptions& options, const std::vector<std::string>& args) {
  options.Check();
  const int port = options.master_port > 0 ? options.master_port : FreePort();
  const bool omp_set = std::getenv("OMP_NUM_THREADS") != nullptr;
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  LOG_INFO("distributed: launching {} workers (ranks {}..{} of {}), {} threads each, rendezvous at {}:{}",
           options.nproc, options.node_rank * options.nproc, options.node_rank * options.nproc + options.nproc - 1,
           options.world_size(),
           omp_set ? std::string(std::getenv("OMP_NUM_THREADS")) : std::to_string(std::max(1u, cores / options.nproc)),
           options.master_addr, port);
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t launcher = getpid();
  std::vector<Worker> workers(options.nproc);
  for (int i = 0; i < options.nproc; ++i) {
    // Everything the child needs is built before fork: between fork and exec only
    // async-signal-safe calls.
    std::vector<std::string> env_strings;
    const auto extra = WorkerEnvironment(options, i, port, cores, omp_set);
    for (char** e = environ; *e != nullptr; ++e) {
      const std::string kv = *e;
      const std::string key = kv.substr(0, kv.find('='));
      bool replaced = false;
      for (const auto& [k, v] : extra) replaced |= k == key;
      if (!replaced) env_strings.push_back(kv);
    }
    for (const auto& [k, v] : extra) env_strings.push_back(k + "=" + v);
    std::vector<char*> envp, argv;
    for (auto& s : env_strings) envp.push_back(s.data());
    envp.push_back(nullptr);
    std::string exe = "/proc/self/exe", name = "nerfreg";
    argv.push_back(name.data());
    std::vector<std::string> args_copy = args;
    for (auto& a : args_copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int devnull = i == 0 ? -1 : open("/dev/null", O_WRONLY | O_CLOEXEC);
    const pid_t pid = fork();
    if (pid < 0) throw DistError("could not start worker " + std::to_string(i) + " (" + std::strerror(errno) + ")");
    if (pid == 0) {
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (getppid() != launcher) _exit(4);             // the launcher died before prctl
      if (devnull >= 0) dup2(devnull, STDOUT_FILENO);  // one result on stdout: rank 0's
      execve(exe.c_str(), argv.data(), envp.data());
      _exit(127);
    }
    if (devnull >= 0) close(devnull);
    workers[i].pid = pid;
    workers[i].rank = options.node_rank * options.nproc + i;
  }
  // Watch: the first failure stops the others; success needs every worker's.
  int remaining = options.nproc;
  const Worker* first_failure = nullptr;
  auto stop_deadline = std::chrono::steady_clock::time_point::max();
  bool killed = false;
  while (remaining > 0) {
    int status = 0;
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid > 0) {
      for (auto& w : workers) {
        if (w.pid != pid || w.done) continue;
        w.done = true;
        w.status = status;
        --remaining;
        if (Failed(status) && first_failure == nullptr) {
          first_failure = &w;
          for (auto& o : workers) {
            if (!o.done) {
              kill(o.pid, SIGTERM);
              o.stopped = true;
            }
          }
          stop_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        }
      }
      continue;
    }
    if (pid < 0 && errno != EINTR) break;
    if (!killed && std::chrono::steady_clock::now() > stop_deadline) {
      for (auto& o : workers) {
        if (!o.done) kill(o.pid, SIGKILL);
      }
      killed = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (first_failure == nullptr) return 0;
  // A worker that lost its peer (exit 4) or that we stopped is a consequence: name the cause, a
  // worker that failed on its own (killed by someone else, or any other exit code).
  const Worker* cause = first_failure;
  for (const auto& w : workers) {
    const bool consequence = w.stopped || (WIFEXITED(w.status) && WEXITSTATUS(w.status) == 4);
    if (Failed(w.status) && !consequence) {
      cause = &w;
      break;
    }
  }
  if (WIFEXITED(cause->status) && WEXITSTATUS(cause->status) == 2) return 2;
  std::fprintf(stderr,
               "error: distributed: rank %d (pid %d) %s; the other ranks were stopped; continue with --resume\n",
               cause->rank, static_cast<int>(cause->pid), Describe(cause->status).c_str());
  return 4;
}

}  // namespace nerfreg
