#include <torch/torch.h>

#include <cstdlib>
#include <thread>

#include "nerfreg/exe/commands.h"
#include "nerfreg/util/threads.h"

namespace nerfreg {

// All hardware threads (LibTorch's default is 1), unless OMP_NUM_THREADS asks for another count.
void InitThreads() {
  torch::set_num_threads(ThreadCount(std::thread::hardware_concurrency(), std::getenv("OMP_NUM_THREADS")));
}

}  // namespace nerfreg
