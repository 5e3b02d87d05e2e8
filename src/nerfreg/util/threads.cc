#include "nerfreg/util/threads.h"

#include <cerrno>
#include <climits>
#include <cstdlib>

namespace nerfreg {

int ThreadCount(unsigned hardware_threads, const char* omp_num_threads, bool* capped) {
  if (capped) *capped = false;
  const int hardware = hardware_threads > 0 && hardware_threads <= INT_MAX ? static_cast<int>(hardware_threads) : 1;
  if (omp_num_threads == nullptr || *omp_num_threads == '\0') return hardware;
  // A whole positive number, as OpenMP reads it; anything else is ignored, as OpenMP does.
  char* end = nullptr;
  errno = 0;
  const long asked = std::strtol(omp_num_threads, &end, 10);
  if (errno != 0 || *end != '\0' || asked < 1) return hardware;
  if (asked > hardware) {
    if (capped) *capped = true;
    return hardware;
  }
  return static_cast<int>(asked);
}

}  // namespace nerfreg
