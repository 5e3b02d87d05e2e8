#include "nerfreg/sfm/rotation_averaging.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "nerfreg/sfm/synthetic_scene_test_util.h"
#include "nerfreg/util/stats.h"

namespace nerfreg {
namespace {

// Rotation error of every camera relative to the root (the gauge), degrees.
std::vector<double> RelativeErrors(const SyntheticScene& s, const RotationAveragingResult& r) {
  std::vector<double> errors;
  const Eigen::Quaterniond gt_root = s.cam_from_world[r.root].rotation;
  for (size_t k = 0; k < s.cam_from_world.size(); ++k) {
    const Eigen::Quaterniond gt = s.cam_from_world[k].rotation * gt_root.inverse();
    errors.push_back(RotationErrorDeg(r.cam_from_world[k], gt));
  }
  return errors;
}

TEST(RotationAveraging, ExactRelativeRotationsGiveExactOrientations) {
  SyntheticSceneOptions o;
  o.num_cameras = 8;
  const SyntheticScene s = MakeSyntheticScene(o);
  const auto r = AverageRotations(s.graph, RotationAveragingOptions{});
  EXPECT_EQ(r.root, 0);
  for (double e : RelativeErrors(s, r)) EXPECT_LT(e, 1e-6);
  for (bool in : r.edge_inlier) EXPECT_TRUE(in);
}

TEST(RotationAveraging, NoisyEdgesAreAveragedAndWrongEdgesRejected) {
  SyntheticSceneOptions o;
  o.num_cameras = 15;
  o.rotation_noise_deg = 0.5;
  o.outlier_edge_fraction = 0.15;
  o.seed = 3;
  const SyntheticScene s = MakeSyntheticScene(o);
  int outliers = 0;
  for (bool b : s.outlier_edge) outliers += b;
  ASSERT_GT(outliers, 5);
  const auto r = AverageRotations(s.graph, RotationAveragingOptions{});
  for (bool c : r.connected) EXPECT_TRUE(c);
  // Each edge's angle is off by ~0.87 deg rms (0.5 deg per axis); each camera averages its ~13
  // good edges. Relative to the fixed root (whose own noise adds in): measured max 0.72 deg.
  const std::vector<double> errors = RelativeErrors(s, r);
  for (double e : errors) EXPECT_LT(e, 0.9);
  std::printf("rotation averaging: median %.3f max %.3f deg\n", Median(errors),
              *std::max_element(errors.begin(), errors.end()));
  EXPECT_LT(Median(errors), 0.45);
  for (size_t k = 0; k < s.graph.edges.size(); ++k) {
    if (s.outlier_edge[k]) {
      // A random rotation can land within 5 deg of the truth only by rare chance.
      EXPECT_FALSE(r.edge_inlier[k]) << "edge " << k << " error " << r.edge_error_deg[k];
    } else {
      EXPECT_TRUE(r.edge_inlier[k]) << "edge " << k << " error " << r.edge_error_deg[k];
    }
  }
}

TEST(RotationAveraging, ImagesOutsideTheLargestComponentAreNotConnected) {
  SyntheticSceneOptions o;
  o.num_cameras = 5;
  SyntheticScene s = MakeSyntheticScene(o);
  s.graph.names.push_back("lonely.png");
  s.graph.keypoints.emplace_back();
  const auto r = AverageRotations(s.graph, RotationAveragingOptions{});
  ASSERT_EQ(r.connected.size(), 6u);
  EXPECT_FALSE(r.connected[5]);
  for (int k = 0; k < 5; ++k) EXPECT_TRUE(r.connected[k]);
}

}  // namespace
}  // namespace nerfreg
