#include <torch/torch.h>

#include <thread>

#include "nerfreg/exe/commands.h"

namespace nerfreg {

void InitThreads() {
  const unsigned n = std::thread::hardware_concurrency();
  torch::set_num_threads(n > 0 ? static_cast<int>(n) : 1);
}

}  // namespace nerfreg
