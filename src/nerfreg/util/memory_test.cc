#include "nerfreg/util/memory.h"

#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

namespace nerfreg {
namespace {

TEST(Memory, PeakResidentSetCoversMemoryTheProcessTouched) {
  const double before = PeakResidentMegabytes();
  EXPECT_GT(before, 0);
  // 128 MB written page by page, so it is resident (an untouched allocation is not).
  std::vector<unsigned char> block(std::size_t(128) << 20);
  unsigned sum = 0;
  for (std::size_t i = 0; i < block.size(); i += 4096) {
    block[i] = static_cast<unsigned char>(i >> 12);
    sum += block[i];
  }
  EXPECT_GT(sum, 0u);
  const double after = PeakResidentMegabytes();
  EXPECT_GE(after, before);
  EXPECT_GE(after, 128);
  EXPECT_LT(after, 1 << 20);  // MB, not kB or bytes: a test process holds well under a TB
}

}  // namespace
}  // namespace nerfreg
