#pragma once

namespace nerfreg {

// The thread count for torch: OMP_NUM_THREADS's value when it is a positive integer (two jobs side
// by side on a small machine each take a share instead of both oversubscribing it), else the
// hardware's (at least 1). `omp_num_threads` may be null (unset).
int ThreadCount(unsigned hardware_threads, const char* omp_num_threads);

}  // namespace nerfreg
