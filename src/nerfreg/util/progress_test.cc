#include "nerfreg/util/progress.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

namespace nerfreg {
namespace {

// A resumed run's rate and ETA are its own: the steps of the run it resumes fill the bar but do not
// count as done in this run's seconds (which made a resumed training report thousands of steps a
// second and an ETA of seconds).
TEST(ProgressBar, AResumedRunsRateCountsOnlyItsOwnSteps) {
  ProgressBar bar("test", 10000, "step");
  bar.Resume(9000);
  EXPECT_EQ(bar.done(), 9000);
  EXPECT_EQ(bar.Rate(), 0.0);
  EXPECT_TRUE(std::isnan(bar.EtaSeconds()));  // nothing done in this run yet: unknown
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  bar.Tick(5);
  // 995 steps left at 5 steps per elapsed time: 199 x elapsed (counting the resumed 9000 would give
  // about 0.11 x elapsed). The clock read before and after brackets the one the ETA used.
  const double before = bar.ElapsedSeconds();
  const double eta = bar.EtaSeconds();
  const double after = bar.ElapsedSeconds();
  EXPECT_GT(eta, 100 * before);
  EXPECT_LT(eta, 200 * after);
  bar.Finish();
}

}  // namespace
}  // namespace nerfreg
