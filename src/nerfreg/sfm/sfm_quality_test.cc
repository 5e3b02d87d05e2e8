#include "nerfreg/sfm/sfm_quality.h"

#include <gtest/gtest.h>

#include "nerfreg/sfm/synthetic_scene_test_util.h"

namespace nerfreg {
namespace {

TEST(SfmQuality, AWellSeenSceneIsWellConstrainedAndThinDataIsNot) {
  SyntheticSceneOptions o;
  o.num_cameras = 8;
  const SyntheticScene s = MakeSyntheticScene(o);
  const SfmResult r = RunGlobalSfm(s.graph, s.cameras, SfmOptions{});
  const SfmQuality q = AssessSfm(r, s.cameras);
  EXPECT_TRUE(q.WellConstrained()) << (q.problems.empty() ? "" : q.problems.front());
  EXPECT_GE(q.min_points_per_image, 20);
  EXPECT_GT(q.median_triangulation_angle_deg, 1.0);

  // The same solution with all but 5 of its points dropped, from images 24 px high.
  SfmResult thin = r;
  thin.points.resize(5);
  std::vector<Camera> tiny = s.cameras;
  for (Camera& c : tiny) {
    c.width = 32;
    c.height = 24;
  }
  const SfmQuality t = AssessSfm(thin, tiny);
  EXPECT_FALSE(t.WellConstrained());
  ASSERT_EQ(t.problems.size(), 2u);  // too few points in an image; too few pixels
  EXPECT_LT(t.min_points_per_image, 20);
  EXPECT_EQ(t.min_image_side_px, 24);

  // The same solution, had the SfM found its centres contradicting the two-view directions.
  SfmResult degenerate = r;
  degenerate.degenerate = "the camera centres contradict the two-view directions";
  const SfmQuality d = AssessSfm(degenerate, s.cameras);
  ASSERT_EQ(d.problems.size(), 1u);
  EXPECT_EQ(d.problems[0], degenerate.degenerate);
}

}  // namespace
}  // namespace nerfreg
