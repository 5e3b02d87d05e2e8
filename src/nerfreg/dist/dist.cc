// The c10d Gloo headers need these (Debian's LibTorch was built with them; its headers are gated).
#define USE_C10D_GLOO 1
#define USE_DISTRIBUTED 1
#include "nerfreg/dist/dist.h"

#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

// NCCL where LibTorch was built with it: its CMake targets then define USE_C10D_NCCL (the CUDA
// wheel's torch_cuda does), and CUDA's include folder holds nccl.h. Debian's CPU LibTorch has neither.
#if defined(USE_C10D_NCCL) && __has_include(<nccl.h>)
#define NERFREG_DIST_NCCL 1
#include <c10/cuda/CUDAFunctions.h>
#include <torch/csrc/distributed/c10d/ProcessGroupNCCL.hpp>
#endif

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

bool NcclAvailable() {
#ifdef NERFREG_DIST_NCCL
  return true;
#else
  return false;
#endif
}

torch::Device ProcessDevice(const torch::Device& requested, const DistOptions& options) {
  if (!requested.is_cuda()) return requested;
  const DistEnv env = DistEnv::FromEnvironment();
  const int nproc = options.nproc;
  const bool several = options.world_size() > 1 || env.world_size > 1;
  if (!several) return requested;
  const std::string name = requested.str();
  if (!NcclAvailable()) {
    ThrowInputError("--device", name, "cpu with several processes (this build's LibTorch has no NCCL)");
  }
  if (requested.index() > 0) {
    ThrowInputError("--device", name, "cuda or auto with several processes (local worker r uses cuda:r)");
  }
  const int gpus = static_cast<int>(torch::cuda::device_count());
  if (nproc > gpus) {
    ThrowInputError("--nproc", std::to_string(nproc),
                    "at most " + std::to_string(gpus) + " processes with --device " + name +
                        " (one GPU each; this machine has " + std::to_string(gpus) + ")");
  }
  if (env.local_rank >= gpus) {
    ThrowInputError("LOCAL_RANK", std::to_string(env.local_rank),
                    "a local rank below this machine's " + std::to_string(gpus) + " GPUs (environment variable)");
  }
  return torch::Device(torch::kCUDA, static_cast<torch::DeviceIndex>(env.local_rank));
}

struct DistGroup::Impl {
  c10::intrusive_ptr<c10d::TCPStore> store;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> pg;
#ifdef NERFREG_DIST_NCCL
  c10::intrusive_ptr<c10d::ProcessGroupNCCL> nccl;  // instead of pg on a GPU; declared after the store, freed first
  bool failed = false;                              // a collective failed: abort, not a graceful shutdown
  ~Impl() {
    if (!nccl) return;
    // Without shutdown() or abort() ProcessGroupNCCL's destructor warns and aborts.
    try {
      if (failed) {
        nccl->abort();
      } else {
        nccl->shutdown();
      }
    } catch (const std::exception&) {
    }
  }
#endif
};

DistGroup::DistGroup() = default;
DistGroup::~DistGroup() = default;

std::string DistGroup::backend() const {
  if (world_size_ == 1) return "none";
  return device_.is_cuda() ? "NCCL" : "Gloo";
}

std::unique_ptr<DistGroup> DistGroup::Join(const DistEnv& env, double timeout_s, const torch::Device& device) {
  auto group = std::make_unique<DistGroup>();
  group->rank_ = env.rank;
  group->world_size_ = env.world_size;
  if (env.world_size == 1) return group;
  const bool nccl = device.is_cuda();
  if (nccl && !NcclAvailable()) {
    throw DistError("rank " + std::to_string(env.rank) + ": " + device.str() +
                    " needs c10d's NCCL backend, which this build's LibTorch lacks");
  }
  group->device_ = nccl ? torch::Device(torch::kCUDA, device.has_index() ? device.index() : 0) : device;
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
#ifdef NERFREG_DIST_NCCL
    if (nccl) {
      // This rank's GPU is the current device (NCCL's communicator and the trainer's tensors
      // there). Blocking wait: a collective that outlasts the timeout throws from wait() (a
      // DistError, exit 4) rather than the watchdog aborting the process. A user's setting stays.
      c10::cuda::set_device(group->device_.index());
      setenv("TORCH_NCCL_BLOCKING_WAIT", "1", 0);
      auto nccl_options = c10d::ProcessGroupNCCL::Options::create();
      nccl_options->timeout = timeout;
      group->impl_->nccl =
          c10::make_intrusive<c10d::ProcessGroupNCCL>(group->impl_->store, env.rank, env.world_size, nccl_options);
      // The communicator now, not at the first collective: a rank that never comes is a
      // rendezvous error, and the communicator is made on this rank's GPU.
      group->impl_->nccl->eagerConnectSingleDevice(group->device_);
      LOG_INFO("distributed: rank {} of {} joined through {}:{} (NCCL) on {}", env.rank, env.world_size,
               env.master_addr, env.master_port, group->device_.str());
      return group;
    }
#endif
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
#ifdef NERFREG_DIST_NCCL
    group->impl_->failed = true;
#endif
    throw DistError("rank " + std::to_string(env.rank) + ": no rendezvous with " + std::to_string(env.world_size) +
                    " processes at " + env.master_addr + ":" + std::to_string(env.master_port) + " within " +
                    std::to_string(static_cast<int>(timeout_s)) + " s (" + std::string(e.what()).substr(0, 200) + ")");
  }
  LOG_INFO("distributed: rank {} of {} joined through {}:{} (Gloo)", env.rank, env.world_size, env.master_addr,
           env.master_port);
  return group;
}

std::unique_ptr<DistGroup> DistGroup::FromEnvironment(double timeout_s, const torch::Device& device) {
  return Join(DistEnv::FromEnvironment(), timeout_s, device);
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

#ifdef NERFREG_DIST_NCCL
// NCCL's Work: wait() blocks (TORCH_NCCL_BLOCKING_WAIT) and throws on an error or a timeout.
// WorkNCCL::isSuccess() is not asked: LibTorch 2.x throws "deprecated" from it.
void WaitNccl(const c10::intrusive_ptr<c10d::Work>& work) {
  if (!work->wait()) throw std::runtime_error("the collective did not complete (aborted)");
}
#endif

// The tensors on `device`: the same ones when they are all there already (the CPU under Gloo),
// else copies (*moved set).
std::vector<torch::Tensor> OnDevice(const std::vector<torch::Tensor>& tensors, const torch::Device& device,
                                    bool* moved) {
  *moved = false;
  for (const auto& t : tensors) *moved |= t.device() != device;
  if (!*moved) return tensors;
  std::vector<torch::Tensor> out;
  for (const auto& t : tensors) out.push_back(t.to(device));
  return out;
}

void CopyBack(std::vector<torch::Tensor>& tensors, const std::vector<torch::Tensor>& on_device) {
  for (size_t i = 0; i < tensors.size(); ++i) {
    if (!on_device[i].is_same(tensors[i])) tensors[i].copy_(on_device[i]);
  }
}

}  // namespace

void DistGroup::AllReduceSum(std::vector<torch::Tensor>& tensors) {
  if (world_size_ == 1) return;
  bool moved = false;
  std::vector<torch::Tensor> work = OnDevice(tensors, device_, &moved);
  try {
#ifdef NERFREG_DIST_NCCL
    if (impl_->nccl) {
      WaitNccl(impl_->nccl->allreduce(work));
    } else
#endif
      // Work::wait() throws for a failed collective, and (LibTorch 2.x's Work.hpp) returns false
      // for an aborted one: both are a lost peer.
      WaitOrThrow(impl_->pg->allreduce(work));
  } catch (const std::exception& e) {
#ifdef NERFREG_DIST_NCCL
    impl_->failed = true;
#endif
    throw DistError("rank " + std::to_string(rank_) + ": a peer was lost during an all-reduce (" + FirstLine(e.what()) +
                    "); continue with --resume");
  }
  if (moved) CopyBack(tensors, work);
}

void DistGroup::Broadcast(std::vector<torch::Tensor>& tensors, int root) {
  if (world_size_ == 1) return;
  c10d::BroadcastOptions options;
  options.rootRank = root;
  bool moved = false;
  std::vector<torch::Tensor> work = OnDevice(tensors, device_, &moved);
  try {
#ifdef NERFREG_DIST_NCCL
    if (impl_->nccl) {
      WaitNccl(impl_->nccl->broadcast(work, options));
    } else
#endif
      WaitOrThrow(impl_->pg->broadcast(work, options));
  } catch (const std::exception& e) {
#ifdef NERFREG_DIST_NCCL
    impl_->failed = true;
#endif
    throw DistError("rank " + std::to_string(rank_) + ": a peer was lost during a broadcast (" + FirstLine(e.what()) +
                    "); continue with --resume");
  }
  if (moved) CopyBack(tensors, work);
}

void BroadcastParameters(DistGroup& group, const std::vector<torch::Tensor>& tensors) {
  if (group.world_size() == 1 || tensors.empty()) return;
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> flat = {torch::cat([&] {
    std::vector<torch::Tensor> parts;
    for (const auto& t : tensors) parts.push_back(t.detach().reshape({-1}).to(group.device(), torch::kFloat64));
    return parts;
  }())};  // [sum of numel], float64 holds every float32 and integer buffer exactly
  group.Broadcast(flat);
  std::int64_t offset = 0;
  for (const auto& t : tensors) {
    const std::int64_t n = t.numel();
    t.detach().copy_(flat[0].slice(0, offset, offset + n).view(t.sizes()).to(t.device(), t.dtype()));
    offset += n;
  }
}

void AllReduceGradients(DistGroup& group, const std::vector<torch::Tensor>& parameters, torch::Tensor* stats) {
  if (group.world_size() == 1) return;
  torch::NoGradGuard no_grad;
  // The buffer lives on the group's device: the CPU under Gloo, this rank's GPU under NCCL (the
  // gradients stay there; only the [P] flags cross, once each way).
  const torch::Device device = group.device();
  const std::int64_t n_params = static_cast<std::int64_t>(parameters.size());
  std::vector<torch::Tensor> parts;
  torch::Tensor defined = torch::zeros({n_params}, torch::kFloat32);  // [P] 1 where this rank has a gradient
  for (std::int64_t i = 0; i < n_params; ++i) {
    const auto& p = parameters[i];
    if (p.grad().defined()) {
      defined[i] = 1;
      parts.push_back(p.grad().reshape({-1}).to(device, torch::kFloat32));
    } else {
      parts.push_back(torch::zeros({p.numel()}, torch::TensorOptions().dtype(torch::kFloat32).device(device)));
    }
  }
  parts.push_back(defined.to(device));
  // Gloo sums the tensors of one call as copies of one tensor (one per device): one call each.
  std::vector<torch::Tensor> buffers = {torch::cat(parts)};  // [sum of numel + P]
  group.AllReduceSum(buffers);
  std::vector<torch::Tensor> stat_buffers;
  if (stats != nullptr) {
    stat_buffers.push_back(stats->contiguous().to(device));
    group.AllReduceSum(stat_buffers);
  }
  std::int64_t offset = 0;
  const torch::Tensor flat = buffers[0];
  const torch::Tensor any = (flat.slice(0, flat.size(0) - n_params) > 0).to(torch::kCPU);  // [P]
  for (std::int64_t i = 0; i < n_params; ++i) {
    auto p = parameters[i];
    const std::int64_t n = p.numel();
    if (any[i].item<bool>()) {
      const torch::Tensor g = flat.slice(0, offset, offset + n).view(p.sizes()).to(p.device(), p.dtype());
      if (p.grad().defined()) {
        p.mutable_grad().copy_(g);
      } else {
        p.mutable_grad() = g.clone();
      }
    }
    offset += n;
  }
  if (stats != nullptr) *stats = stat_buffers[0].to(stats->device());
}

}  // namespace nerfreg
