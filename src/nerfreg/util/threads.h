#pragma once

namespace nerfreg {

// The thread count for torch: OMP_NUM_THREADS's value when it is a positive integer (two jobs side
// by side on a small machine each take a share instead of both oversubscribing it), else the
// hardware's (at least 1). `omp_num_threads` may be null (unset). A value above the hardware's
// count is capped to it (1000 threads on 2 cores made a run 20x slower) and *capped is set.
int ThreadCount(unsigned hardware_threads, const char* omp_num_threads, bool* capped = nullptr);

}  // namespace nerfreg
