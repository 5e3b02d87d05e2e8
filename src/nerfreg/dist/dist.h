#pragma once
// Data-parallel training across processes on torch's c10d with the Gloo backend (CPU, TCP): the
// group a process joins from torchrun's environment variables, and the two collectives a trainer
// needs (parameters broadcast from rank 0 at the start, gradients summed every step). The c10d
// headers stay inside dist.cc. See docs/distributed.md; the launcher is launch.h.
#include <torch/torch.h>

#include <memory>
#include <string>
#include <vector>

namespace nerfreg {

// Where this process sits in a job, as torchrun describes it: RANK, WORLD_SIZE, LOCAL_RANK,
// MASTER_ADDR, MASTER_PORT.
struct DistEnv {
  int rank = 0, world_size = 1, local_rank = 0;
  std::string master_addr = "127.0.0.1";
  int master_port = 0;
  // RANK unset: a single process (world 1). Throws InputError naming the variable when one is
  // malformed or inconsistent (RANK >= WORLD_SIZE, no MASTER_PORT).
  static DistEnv FromEnvironment();
};

// One process group. A default-constructed group is the single process: every collective is a
// no-op, so a trainer runs one code path.
class DistGroup {
 public:
  DistGroup();
  ~DistGroup();
  DistGroup(const DistGroup&) = delete;
  DistGroup& operator=(const DistGroup&) = delete;

  // Joins the job `env` describes: rank 0 serves a c10d TCPStore at MASTER_ADDR:MASTER_PORT, every
  // rank rendezvous there and opens a ProcessGroupGloo. `timeout_s` bounds the rendezvous and
  // every collective, so a peer that stops answering is an error, not a hang (a peer that dies is
  // noticed at once: its sockets close). Ranks other than 0 lower their logging to warnings.
  // Throws DistError when the rendezvous fails.
  static std::unique_ptr<DistGroup> Join(const DistEnv& env, double timeout_s);
  // The group for this process: Join(FromEnvironment()) under a launcher, else a single process.
  static std::unique_ptr<DistGroup> FromEnvironment(double timeout_s);

  int rank() const { return rank_; }
  int world_size() const { return world_size_; }
  bool is_main() const { return rank_ == 0; }

  // In place; every rank passes tensors of the same shapes and dtypes, in the same order. Gloo
  // treats the tensors of one call as one tensor's copies (their shapes must match).
  // Throw DistError when a peer is lost or times out.
  void AllReduceSum(std::vector<torch::Tensor>& tensors);
  void Broadcast(std::vector<torch::Tensor>& tensors, int root = 0);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int rank_ = 0, world_size_ = 1;
};

// Copies rank 0's parameter values (and buffers) into every rank's, in place.
void BroadcastParameters(DistGroup& group, const std::vector<torch::Tensor>& tensors);

// Sums each parameter's gradient over the ranks, in one flat buffer, and `stats` ([K] float64,
// e.g. a loss sum and a sample count) with them. A gradient undefined on every rank stays
// undefined (an optimizer skips that parameter, as a single process would); one undefined on some
// ranks only counts as zeros there. Gradients are summed, not averaged: the trainer divides by
// the number of samples over all ranks, so N processes match one process with the same batch.
void AllReduceGradients(DistGroup& group, const std::vector<torch::Tensor>& parameters, torch::Tensor* stats);

}  // namespace nerfreg
