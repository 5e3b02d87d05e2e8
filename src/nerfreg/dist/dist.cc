// The c10d Gloo headers need these (Debian's LibTorch was built with them; its headers are gated).
#define USE_C10D_GLOO 1
#define USE_DISTRIBUTED 1
#include "nerfreg/dist/dist.h"

#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include <chrono>
#include <csignal>
#include <cstdlib>

#include "nerfreg/dist/launch.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

namespace {

int EnvInt(const char* name, int fallback, int min_value) {
  const char* v = std::getenv(name);
  if (v == nullptr || *v == '\0') return fallback;
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  if (*end != '\0' || x < min_value || x > 1 << 20) {
    ThrowInputError(name, "", "an integer >= " + std::to_string(min_value) + " (environment variable)");
  }
  return static_cast<int>(x);
}

bool IsLoopback(const std::string& addr) { return addr == "localhost" || addr.rfind("127.", 0) == 0; }

}  // namespace

DistEnv DistEnv::FromEnvironment() {
  DistEnv env;
  if (std::getenv("RANK") == nullptr) return env;
  env.rank = EnvInt("RANK", 0, 0);
  env.world_size = EnvInt("WORLD_SIZE", 1, 1);
  env.local_rank = EnvInt("LOCAL_RANK", env.rank, 0);
  if (env.rank >= env.world_size)
    ThrowInputError("RANK", "", "a rank below WORLD_SIZE (" + std::to_string(env.world_size) + ")");
  if (const char* a = std::getenv("MASTER_ADDR"); a != nullptr && *a != '\0') env.master_addr = a;
  env.master_port = EnvInt("MASTER_PORT", 0, 1);
  if (env.world_size > 1 && (env.master_port < 1 || env.master_port > 65535)) {
    ThrowInputError("MASTER_PORT", "", "a TCP port in [1, 65535] (environment variable)");
  }
  return env;
}

struct DistGroup::Impl {
  c10::intrusive_ptr<c10d::TCPStore> store;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> pg;
};

DistGroup::DistGroup() = default;
DistGroup::~DistGroup() = default;

std::unique_ptr<DistGroup> DistGroup::Join(const DistEnv& env, double timeout_s) {
  auto group = std::make_unique<DistGroup>();
  group->rank_ = env.rank;
  group->world_size_ = env.world_size;
  if (env.world_size == 1) return group;
  if (env.rank != 0) {
    LogOptions quiet = CurrentLogOptions();
    quiet.quiet = true;
    quiet.verbose = false;
    InitLogging(quiet);
  }
  // A write to a peer that has died raises SIGPIPE, whose default action ends this process
  // silently (the ctest run saw it). Ignored, as Python ignores it for torch.distributed, the
  // write fails with EPIPE and Gloo throws, which AllReduceSum turns into a DistError.
  std::signal(SIGPIPE, SIG_IGN);
  const auto timeout = std::chrono::milliseconds(static_cast<std::int64_t>(timeout_s * 1000));
  group->impl_ = std::make_unique<Impl>();
  try {
    c10d::TCPStoreOptions so;
    so.port = static_cast<std::uint16_t>(env.master_port);
    so.isServer = env.rank == 0;
    so.numWorkers = env.world_size;
    so.waitWorkers = false;
    so.timeout = timeout;
    group->impl_->store = c10::make_intrusive<c10d::TCPStore>(env.master_addr, so);
    auto options = c10d::ProcessGroupGloo::Options::create(timeout);
    // The interface Gloo listens on: GLOO_SOCKET_IFNAME as torchrun, else loopback for a job on
    // one machine, else the one this host's name resolves to.
    if (const char* ifname = std::getenv("GLOO_SOCKET_IFNAME"); ifname != nullptr && *ifname != '\0') {
      options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForInterface(ifname));
    } else if (IsLoopback(env.master_addr)) {
      options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1"));
    } else {
      options->devices.push_back(c10d::ProcessGroupGloo::createDefaultDevice());
    }
    group->impl_->pg =
        c10::make_intrusive<c10d::ProcessGroupGloo>(group->impl_->store, env.rank, env.world_size, options);
  } catch (const std::exception& e) {
    throw DistError("rank " + std::to_string(env.rank) + ": no rendezvous with " + std::to_string(env.world_size) +
                    " processes at " + env.master_addr + ":" + std::to_string(env.master_port) + " within " +
                    std::to_string(static_cast<int>(timeout_s)) + " s (" + std::string(e.what()).substr(0, 200) + ")");
  }
  LOG_INFO("distributed: rank {} of {} joined through {}:{} (Gloo)", env.rank, env.world_size, env.master_addr,
           env.master_port);
  return group;
}

std::unique_ptr<DistGroup> DistGroup::FromEnvironment(double timeout_s) {
  return Join(DistEnv::FromEnvironment(), timeout_s);
}

namespace {

// The first line of a c10d / Gloo message (they carry a C++ backtrace after it).
std::string FirstLine(const std::string& s) {
  const std::string line = s.substr(0, s.find('\n'));
  return line.size() > 200 ? line.substr(0, 200) : line;
}

// A collective that ends without success: its message for the caller's DistError.
void WaitOrThrow(const c10::intrusive_ptr<c10d::Work>& work) {
  if (!work->wait() || !work->isSuccess()) {
    throw std::runtime_error("the collective did not complete (aborted)");
  }
}

}  // namespace

void DistGroup::AllReduceSum(std::vector<torch::Tensor>& tensors) {
  if (world_size_ == 1) return;
  try {
    // Work::wait() throws for a failed collective, and (LibTorch 2.x's Work.hpp) returns false
    // for an aborted one: both are a lost peer.
    WaitOrThrow(impl_->pg->allreduce(tensors));
  } catch (const std::exception& e) {
    throw DistError("rank " + std::to_string(rank_) + ": a peer was lost during an all-reduce (" + FirstLine(e.what()) +
                    "); continue with --resume");
  }
}

void DistGroup::Broadcast(std::vector<torch::Tensor>& tensors, int root) {
  if (world_size_ == 1) return;
  c10d::BroadcastOptions options;
  options.rootRank = root;
  try {
    WaitOrThrow(impl_->pg->broadcast(tensors, options));
  } catch (const std::exception& e) {
    throw DistError("rank " + std::to_string(rank_) + ": a peer was lost during a broadcast (" + FirstLine(e.what()) +
                    "); continue with --resume");
  }
}

void BroadcastParameters(DistGroup& group, const std::vector<torch::Tensor>& tensors) {
  if (group.world_size() == 1 || tensors.empty()) return;
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> flat = {torch::cat([&] {
    std::vector<torch::Tensor> parts;
    for (const auto& t : tensors) parts.push_back(t.detach().reshape({-1}).to(torch::kFloat64));
    return parts;
  }())};  // [sum of numel], float64 holds every float32 and integer buffer exactly
  group.Broadcast(flat);
  std::int64_t offset = 0;
  for (const auto& t : tensors) {
    const std::int64_t n = t.numel();
    t.detach().copy_(flat[0].slice(0, offset, offset + n).view(t.sizes()).to(t.dtype()));
    offset += n;
  }
}

void AllReduceGradients(DistGroup& group, const std::vector<torch::Tensor>& parameters, torch::Tensor* stats) {
  if (group.world_size() == 1) return;
  torch::NoGradGuard no_grad;
  const std::int64_t n_params = static_cast<std::int64_t>(parameters.size());
  std::vector<torch::Tensor> parts;
  torch::Tensor defined = torch::zeros({n_params}, torch::kFloat32);  // [P] 1 where this rank has a gradient
  for (std::int64_t i = 0; i < n_params; ++i) {
    const auto& p = parameters[i];
    if (p.grad().defined()) {
      defined[i] = 1;
      parts.push_back(p.grad().reshape({-1}).to(torch::kFloat32));
    } else {
      parts.push_back(torch::zeros({p.numel()}, torch::kFloat32));
    }
  }
  parts.push_back(defined);
  // Gloo sums the tensors of one call as copies of one tensor (one per device): one call each.
  std::vector<torch::Tensor> buffers = {torch::cat(parts)};  // [sum of numel + P]
  group.AllReduceSum(buffers);
  std::vector<torch::Tensor> stat_buffers;
  if (stats != nullptr) {
    stat_buffers.push_back(stats->contiguous());
    group.AllReduceSum(stat_buffers);
  }
  std::int64_t offset = 0;
  const torch::Tensor flat = buffers[0];
  const torch::Tensor any = flat.slice(0, flat.size(0) - n_params) > 0;  // [P]
  for (std::int64_t i = 0; i < n_params; ++i) {
    auto p = parameters[i];
    const std::int64_t n = p.numel();
    if (any[i].item<bool>()) {
      const torch::Tensor g = flat.slice(0, offset, offset + n).view(p.sizes()).to(p.dtype());
      if (p.grad().defined()) {
        p.mutable_grad().copy_(g);
      } else {
        p.mutable_grad() = g.clone();
      }
    }
    offset += n;
  }
  if (stats != nullptr) *stats = stat_buffers[0];
}

}  // namespace nerfreg
