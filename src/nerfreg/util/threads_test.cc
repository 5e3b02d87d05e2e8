#include "nerfreg/util/threads.h"

#include <gtest/gtest.h>

namespace nerfreg {
namespace {

TEST(Threads, OmpNumThreadsWinsWhenItIsAPositiveWholeNumber) {
  EXPECT_EQ(ThreadCount(16, nullptr), 16);
  EXPECT_EQ(ThreadCount(16, ""), 16);
  EXPECT_EQ(ThreadCount(16, "1"), 1);
  EXPECT_EQ(ThreadCount(4, "2"), 2);
  // More than the hardware has: capped, and said so (the binary warns).
  bool capped = false;
  EXPECT_EQ(ThreadCount(2, "1000", &capped), 2);
  EXPECT_TRUE(capped);
  EXPECT_EQ(ThreadCount(2, "2", &capped), 2);
  EXPECT_FALSE(capped);
  // Not a count: the hardware's, as OpenMP ignores it.
  for (const char* bad : {"0", "-2", "two", "3x", "99999999999999999999"}) EXPECT_EQ(ThreadCount(4, bad), 4) << bad;
  EXPECT_EQ(ThreadCount(0, nullptr), 1);  // hardware_concurrency() may not know
}

}  // namespace
}  // namespace nerfreg
