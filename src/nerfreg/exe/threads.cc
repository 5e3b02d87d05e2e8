#include <torch/torch.h>

#include <cstdlib>
#include <thread>

#include "nerfreg/exe/commands.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/threads.h"

namespace nerfreg {

// All hardware threads (LibTorch's default is 1), unless OMP_NUM_THREADS asks for another count.
void InitThreads() {
  bool capped = false;
  const int threads = ThreadCount(std::thread::hardware_concurrency(), std::getenv("OMP_NUM_THREADS"), &capped);
  if (capped) {
    LOG_WARN(
        "OMP_NUM_THREADS={} asks for more threads than this machine's {}: using {} (more threads than cores "
        "only slow every step down)",
        std::getenv("OMP_NUM_THREADS"), threads, threads);
  }
  torch::set_num_threads(threads);
}

}  // namespace nerfreg
