#include "nerfreg/util/stage_times.h"

#include <gtest/gtest.h>

namespace nerfreg {
namespace {

TEST(StageTimes, RepeatedStagesAddUpInFirstRunOrder) {
  StageTimes t;
  t.Add("matching", 2.0);
  t.Add("features", 1.0);
  t.Add("matching", 0.5);
  StageTimes more;
  more.Add("bundle adjustment", 3.0);
  more.Add("features", 0.25);
  t.Append(more);
  ASSERT_EQ(t.stages().size(), 3u);
  EXPECT_EQ(t.stages()[0].first, "matching");
  EXPECT_EQ(t.stages()[2].first, "bundle adjustment");
  EXPECT_DOUBLE_EQ(t.Seconds("matching"), 2.5);
  EXPECT_DOUBLE_EQ(t.Seconds("features"), 1.25);
  EXPECT_DOUBLE_EQ(t.Seconds("absent"), 0.0);
  const Json j = t.ToJson();
  EXPECT_EQ(j.size(), 3u);
  EXPECT_DOUBLE_EQ(j["bundle adjustment"].get<double>(), 3.0);
  EXPECT_EQ(t.Summary(), "matching 2.50, features 1.25, bundle adjustment 3.00");
}

}  // namespace
}  // namespace nerfreg
