#pragma once
// `--nproc N`: a command starts N worker copies of itself on this machine with torchrun's
// environment (RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR, MASTER_PORT) and watches them. With
// `--nnodes M --node-rank K` the same command on each of M machines starts its N workers, ranks
// K*N .. K*N+N-1 of M*N, all meeting at --master-addr:--master-port. See docs/distributed.md.
#include <stdexcept>
#include <string>
#include <vector>

namespace nerfreg {

// A process of a distributed job was lost or did not answer in time (the error tiers of
// util/error.h): caught in main, printed as one line `error: distributed: ...`, exit code 4.
class DistError : public std::runtime_error {
 public:
  explicit DistError(const std::string& message) : std::runtime_error(message) {}
};

struct DistOptions {
  int nproc = 1;                          // workers on this machine
  int nnodes = 1, node_rank = 0;          // machines in the job, and this one's index
  std::string master_addr = "127.0.0.1";  // where rank 0 serves the rendezvous store
  int master_port = 0;                    // 0: a free port (one machine only)
  double timeout_s = 120;                 // rendezvous, and any one collective (a peer that stops answering)
  void Check() const;                     // throws InputError naming the option
  int world_size() const { return nproc * nnodes; }
};

// True for the command a user ran with --nproc / --nnodes: it launches, it does not train. False
// in a worker (RANK is set) and for a single process.
bool ShouldLaunch(const DistOptions& options);

// The environment of local worker `local_rank` (the variables that differ from this process's).
std::vector<std::pair<std::string, std::string>> WorkerEnvironment(const DistOptions& options, int local_rank, int port,
                                                                   unsigned hardware_threads, bool omp_threads_set);

// Starts options.nproc workers running this executable with `args` (argv without argv[0]), each
// with WorkerEnvironment (threads: this machine's cores / nproc, unless OMP_NUM_THREADS is set),
// their stdout only from local rank 0, and waits. When a worker fails, the others are stopped
// (SIGTERM, SIGKILL after 5 s) and the launch returns: 2 when that worker failed on bad input (it
// printed the line), else 4 after one line `error: distributed: rank R ...` naming it. 0 when all
// workers succeeded. Workers die with the launcher (PR_SET_PDEATHSIG).
int LaunchWorkers(const DistOptions& options, const std::vector<std::string>& args);

}  // namespace nerfreg
