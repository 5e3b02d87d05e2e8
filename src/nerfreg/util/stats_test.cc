#include "nerfreg/util/stats.h"

#include <gtest/gtest.h>

namespace nerfreg {
namespace {

TEST(Stats, MedianAveragesTheMiddlePairAndUpperMedianTakesTheLarger) {
  EXPECT_DOUBLE_EQ(Median({}), 0.0);
  EXPECT_DOUBLE_EQ(Median({3, 1, 2}), 2.0);
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(UpperMedian({}), 0.0);
  EXPECT_DOUBLE_EQ(UpperMedian({3, 1, 2}), 2.0);
  EXPECT_DOUBLE_EQ(UpperMedian({4, 1, 3, 2}), 3.0);
  // Order does not matter and the input is left alone (taken by value).
  const std::vector<double> v = {9, -1, 5, 7, 0, 2};
  EXPECT_DOUBLE_EQ(Median(v), 3.5);
  EXPECT_EQ(v.front(), 9);
}

}  // namespace
}  // namespace nerfreg
