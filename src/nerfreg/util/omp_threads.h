#pragma once

// Header-only: for the libraries that link OpenMP themselves (the learned core's util does not,
// so that a CUDA build with PyTorch's own OpenMP runtime does not load a second one).
#include <omp.h>

namespace nerfreg {

// The calling thread's OpenMP thread count set to `threads` while it lives, the previous count
// restored after. OpenMP keeps the count per thread, so a worker of another pool (OpenCV's TBB)
// changes only its own: for libraries that run on OpenMP (Open3D, oneDNN) called where the
// caller already spreads the work over the cores, or where the thread count changes the result.
class ScopedOmpThreads {
 public:
  explicit ScopedOmpThreads(int threads) : previous_(omp_get_max_threads()) {
    omp_set_num_threads(threads < 1 ? 1 : threads);
  }
  ~ScopedOmpThreads() { omp_set_num_threads(previous_); }
  ScopedOmpThreads(const ScopedOmpThreads&) = delete;
  ScopedOmpThreads& operator=(const ScopedOmpThreads&) = delete;

 private:
  int previous_;
};

}  // namespace nerfreg
