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

  // The same points, each seen by two images only: every image keeps its points, but its pose rests
  // on pairs alone.
  EXPECT_GE(q.min_multiview_points_per_image, 10);
  SfmResult pairs_only = r;
  for (size_t i = 0; i < pairs_only.points.size(); ++i) {
    std::vector<TrackElement>& e = pairs_only.points[i].elements;
    if (e.size() <= 2) continue;
    const size_t a = i % e.size();  // a different pair of the track's images for each point
    e = {e[a], e[(a + 1) % e.size()]};
  }
  const SfmQuality po = AssessSfm(pairs_only, s.cameras);
  EXPECT_EQ(po.min_multiview_points_per_image, 0);
  EXPECT_GE(po.min_points_per_image, 20);
  ASSERT_FALSE(po.WellConstrained());
  EXPECT_NE(po.problems.back().find("3 or more images"), std::string::npos) << po.problems.back();

  // The same solution, had the SfM found its centres contradicting the two-view directions.
  SfmResult degenerate = r;
  degenerate.degenerate = "the camera centres contradict the two-view directions";
  const SfmQuality d = AssessSfm(degenerate, s.cameras);
  ASSERT_EQ(d.problems.size(), 1u);
  EXPECT_EQ(d.problems[0], degenerate.degenerate);
}

}  // namespace
}  // namespace nerfreg
