#include "nerfreg/sfm/global_positioning.h"

#include <gtest/gtest.h>

#include "nerfreg/sfm/global_sfm.h"
#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/sfm/synthetic_scene_test_util.h"

namespace nerfreg {
namespace {

TEST(GlobalPositioning, RandomStartGivesTheTrueCentresFromRaysAndRotations) {
  SyntheticSceneOptions o;
  o.num_cameras = 10;
  o.keypoint_noise_px = 0.3;
  o.seed = 3;
  const SyntheticScene s = MakeSyntheticScene(o);
  const std::vector<Track> tracks = BuildTracks(s.graph, {}, TrackOptions{});
  const GlobalPositioningResult r = PositionCamerasAndPoints(tracks, s.graph.keypoints, s.cameras, TrueRotations(s),
                                                             std::vector<bool>(10, true), GlobalPositioningOptions{});
  std::vector<Rigid3d> est;
  for (int k = 0; k < 10; ++k) {
    ASSERT_TRUE(r.solved[k]);
    est.push_back(Rigid3d(s.cam_from_world[k].rotation, -(s.cam_from_world[k].rotation * r.centers[k])));
  }
  const PoseEvaluation e = EvaluatePoses(est, s.cam_from_world, PoseAlignment::kCenters);
  ASSERT_TRUE(e.aligned);
  // Rays alone, no bundle adjustment yet: centres within 1 % of the widest baseline.
  for (double c : e.center_error) EXPECT_LT(c / e.widest_baseline, 0.01);
  EXPECT_GT(r.num_observations, 1000);
  // An image without orientation is neither solved nor moved.
  std::vector<bool> oriented(10, true);
  oriented[4] = false;
  const GlobalPositioningResult partial =
      PositionCamerasAndPoints(tracks, s.graph.keypoints, s.cameras, TrueRotations(s), oriented, {});
  EXPECT_FALSE(partial.solved[4]);
  EXPECT_EQ(partial.centers[4], Eigen::Vector3d::Zero());
}

// Pairwise directions all wrong (random), rotations and matches right: translation averaging puts
// cameras on top of each other; the SfM sees centres that coincide although their matches show
// parallax, solves again by global positioning, and returns the true cameras.
TEST(GlobalSfm, ACollapsedTranslationSolutionIsDetectedAndSolvedAgain) {
  SyntheticSceneOptions o;
  o.num_cameras = 10;
  o.seed = 5;
  SyntheticScene s = MakeSyntheticScene(o);
  // All directions point one way: the centres collapse onto a line through one point.
  for (auto& e : s.graph.edges)
    e.j_from_i.translation = (e.j_from_i.rotation * Eigen::Vector3d(0, 0, 1e-3)).normalized();
  SfmOptions options;
  options.positioning = SfmPositioning::kTranslationAveraging;
  options.collapse_retries = 0;
  const SfmResult collapsed = RunGlobalSfm(s.graph, s.cameras, options);
  int left_out = 0;
  for (size_t k = 0; k < collapsed.posed.size(); ++k) {
    if (collapsed.posed[k]) continue;
    ++left_out;
    EXPECT_NE(collapsed.not_posed_reason[k].find("collapsed"), std::string::npos) << collapsed.not_posed_reason[k];
  }
  EXPECT_GT(left_out, 0) << "the constructed graph no longer collapses translation averaging";

  options.collapse_retries = 2;
  const SfmResult r = RunGlobalSfm(s.graph, s.cameras, options);
  EXPECT_GE(r.num_collapse_resolves, 1);
  for (bool p : r.posed) EXPECT_TRUE(p);
  const PoseEvaluation e = EvaluatePoses(r.cam_from_world, s.cam_from_world, PoseAlignment::kRotationsAndCenters);
  ASSERT_TRUE(e.aligned);
  EXPECT_LT(e.median_rotation_deg, 0.15);
  for (double c : e.center_error) EXPECT_LT(c / e.widest_baseline, 0.005);
}

}  // namespace
}  // namespace nerfreg
