#pragma once
// Data-parallel training across processes on torch's c10d: the Gloo backend (TCP) for a CPU job,
// NCCL for a CUDA one (the CUDA build, where LibTorch has it): the group a process joins from
// torchrun's environment variables, and the two collectives a trainer needs (parameters broadcast
// from rank 0 at the start, gradients summed every step). The c10d headers stay inside dist.cc.
// See docs/distributed.md; the launcher is launch.h.
#include <torch/torch.h>

#include <memory>
#include <string>
#include <vector>

#include "nerfreg/dist/launch.h"  // DistOptions

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

// Whether this build's LibTorch has c10d's NCCL backend (the CUDA build).
bool NcclAvailable();

// The device this process trains on, given the parsed --device and the command's --nproc /
// --nnodes. The CPU stays the CPU. A CUDA device in a job of several processes is
// cuda:LOCAL_RANK (torchrun's convention: local worker r uses GPU r; the launcher itself gets
// cuda:0). Throws InputError naming --nproc when this machine has fewer GPUs than --nproc, naming
// --device for cuda:N with N > 0 under several processes or when LibTorch has no NCCL, and naming
// LOCAL_RANK for a worker whose local rank has no GPU. A single process keeps the device asked.
torch::Device ProcessDevice(const torch::Device& requested, const DistOptions& options);

// One process group. A default-constructed group is the single process: every collective is a
// no-op, so a trainer runs one code path.
class DistGroup {
 public:
  DistGroup();
  ~DistGroup();
  DistGroup(const DistGroup&) = delete;
  DistGroup& operator=(const DistGroup&) = delete;

  // Joins the job `env` describes: rank 0 serves a c10d TCPStore at MASTER_ADDR:MASTER_PORT, every
  // rank rendezvous there and opens a ProcessGroupGloo, or with a CUDA `device` (ProcessDevice's)
  // a ProcessGroupNCCL on that device. `timeout_s` bounds the rendezvous and every collective, so
  // a peer that stops answering is an error, not a hang (under Gloo a peer that dies is noticed at
  // once: its sockets close). Ranks other than 0 lower their logging to warnings. Throws
  // DistError when the rendezvous fails or NCCL is asked of a LibTorch without it.
  static std::unique_ptr<DistGroup> Join(const DistEnv& env, double timeout_s,
                                         const torch::Device& device = torch::kCPU);
  // The group for this process: Join(FromEnvironment()) under a launcher, else a single process.
  static std::unique_ptr<DistGroup> FromEnvironment(double timeout_s, const torch::Device& device = torch::kCPU);

  int rank() const { return rank_; }
  int world_size() const { return world_size_; }
  bool is_main() const { return rank_ == 0; }
  // Where the collectives run: the CPU (Gloo, or a single process) or this rank's GPU (NCCL).
  const torch::Device& device() const { return device_; }
  // "Gloo", "NCCL", or "none" for a single process.
  std::string backend() const;

  // In place; every rank passes tensors of the same shapes and dtypes, in the same order. Gloo
  // treats the tensors of one call as one tensor's copies (their shapes must match); NCCL takes
  // one tensor per call. Tensors elsewhere than device() (a CPU table under NCCL) are copied
  // there for the collective and the result back into them.
  // Throw DistError when a peer is lost or times out.
  void AllReduceSum(std::vector<torch::Tensor>& tensors);
  void Broadcast(std::vector<torch::Tensor>& tensors, int root = 0);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int rank_ = 0, world_size_ = 1;
  torch::Device device_ = torch::kCPU;
};

// Copies rank 0's parameter values (and buffers) into every rank's, in place.
void BroadcastParameters(DistGroup& group, const std::vector<torch::Tensor>& tensors);

// Sums each parameter's gradient over the ranks, in one flat buffer, and `stats` ([K] float64,
// e.g. a loss sum and a sample count) with them, on the group's device (`stats` comes back on its
// own device; the gradients on their parameters'). A gradient undefined on every rank stays
// undefined (an optimizer skips that parameter, as a single process would); one undefined on some
// ranks only counts as zeros there. Gradients are summed, not averaged: the trainer divides by
// the number of samples over all ranks, so N processes match one process with the same batch.
void AllReduceGradients(DistGroup& group, const std::vector<torch::Tensor>& parameters, torch::Tensor* stats);

}  // namespace nerfreg
