#include "nerfreg/util/memory.h"

#include <sys/resource.h>

namespace nerfreg {

double PeakResidentMegabytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux reports kilobytes
}

}  // namespace nerfreg
