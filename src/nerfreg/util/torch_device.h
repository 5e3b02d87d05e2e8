#pragma once
// The compute device a command runs on (`--device cpu|cuda[:N]|auto`), parsed once, and the
// compatibility shims between the LibTorch versions nerfreg builds against (Debian's 1.13 CPU
// build, and 2.x with CUDA for the GPU build). Header-only and included by the LibTorch layers
// alone: the util library itself stays torch-free (the sanitizer build).
#include <torch/torch.h>

#include <cctype>
#include <string>
#include <utility>

#include "nerfreg/util/error.h"

// LibTorch 2.x dropped the C++ API's torch/linalg.h (namespace torch::linalg); ATen's functions of
// the same names exist in 1.13 and 2.x. Under 2.x this gives back the names the code uses.
#if !__has_include(<torch/linalg.h>)
namespace torch::linalg {
template <class... A>
auto inv(A&&... a) {
  return at::linalg_inv(std::forward<A>(a)...);
}
template <class... A>
auto det(A&&... a) {
  return at::linalg_det(std::forward<A>(a)...);
}
template <class... A>
auto svd(A&&... a) {
  return at::linalg_svd(std::forward<A>(a)...);
}
template <class... A>
auto qr(A&&... a) {
  return at::linalg_qr(std::forward<A>(a)...);
}
}  // namespace torch::linalg
#endif

namespace nerfreg {

// Whether this build's LibTorch can reach a CUDA device now (false on a CPU-only LibTorch).
inline bool CudaAvailable() { return torch::cuda::is_available(); }

// "cpu", "cuda" (device 0), "cuda:N" or "auto" (cuda:0 where a GPU is present, else cpu).
// Throws InputError naming `flag` for anything else, and for a CUDA device this machine or this
// build does not have: `error: --device: cuda: expected ... (no CUDA device ...)`, exit 2.
inline torch::Device ParseDevice(const std::string& text, const std::string& flag = "--device") {
  if (text == "cpu") return torch::Device(torch::kCPU);
  if (text == "auto") return CudaAvailable() ? torch::Device(torch::kCUDA, 0) : torch::Device(torch::kCPU);
  if (text == "cuda" || text.rfind("cuda:", 0) == 0) {
    int index = 0;
    if (text.size() > 5) {
      const std::string digits = text.substr(5);
      bool ok = !digits.empty() && digits.size() <= 3;
      for (const char c : digits) ok = ok && std::isdigit(static_cast<unsigned char>(c));
      if (!ok) ThrowInputError(flag, text, "cpu, cuda, cuda:N (N a device index) or auto");
      index = std::stoi(digits);
    }
    if (!CudaAvailable()) {
      ThrowInputError(flag, text,
                      "a CUDA device (none is available: this build's LibTorch has no CUDA or the machine has no GPU; "
                      "use --device cpu or auto)");
    }
    const int count = static_cast<int>(torch::cuda::device_count());
    if (index >= count) {
      ThrowInputError(flag, text, "a CUDA device index below " + std::to_string(count) + " (this machine's GPU count)");
    }
    return torch::Device(torch::kCUDA, static_cast<torch::DeviceIndex>(index));
  }
  ThrowInputError(flag, text, "cpu, cuda, cuda:N (N a device index) or auto");
}

// The device's name as the flag takes it ("cpu", "cuda:0").
inline std::string DeviceName(const torch::Device& device) { return device.str(); }

// An Adam / AdamW optimizer's moments to `device`. A checkpoint is read on the CPU (it may have
// been written on another device), and a step needs the state where the gradients are.
inline void MoveOptimizerState(torch::optim::Optimizer& optimizer, const torch::Device& device) {
  const auto move = [&](auto& s) {
    if (s.exp_avg().defined()) s.exp_avg(s.exp_avg().to(device));
    if (s.exp_avg_sq().defined()) s.exp_avg_sq(s.exp_avg_sq().to(device));
    if (s.max_exp_avg_sq().defined()) s.max_exp_avg_sq(s.max_exp_avg_sq().to(device));
  };
  for (auto& entry : optimizer.state()) {
    if (auto* adam = dynamic_cast<torch::optim::AdamParamState*>(entry.second.get())) move(*adam);
    if (auto* adamw = dynamic_cast<torch::optim::AdamWParamState*>(entry.second.get())) move(*adamw);
  }
}

}  // namespace nerfreg
