// The machine's streaming memory bandwidth (a STREAM-triad-like loop over 2 x 256 MB arrays), the
// bound the hash-encoding benchmark is compared with (results/nerf_blocks.md).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

int main() {
  const size_t n = size_t(1) << 26;  // 2^26 floats = 256 MB per array
  std::vector<float> a(n, 1.f), b(n, 2.f);
  double best = 0;
  for (int r = 0; r < 5; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for
    for (size_t i = 0; i < n; ++i) a[i] = b[i] * 1.0001f + a[i];
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best = std::max(best, 3.0 * n * sizeof(float) / s / 1e9);  // read a and b, write a
  }
  std::printf("streaming bandwidth: %.1f GB/s (%d threads, best of 5)\n", best, omp_get_max_threads());
  return 0;
}
