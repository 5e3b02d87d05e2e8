#include "nerfreg/sfm/translation_averaging.h"

#include <gtest/gtest.h>

#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/sfm/synthetic_scene_test_util.h"

namespace nerfreg {
namespace {

// Centres of the result against the ground truth after a Sim(3) fit, as % of the widest baseline.
double MaxCenterErrorPercent(const SyntheticScene& s, const TranslationAveragingResult& r) {
  std::vector<Rigid3d> est;
  for (size_t k = 0; k < s.cam_from_world.size(); ++k) {
    const Eigen::Quaterniond rot = s.cam_from_world[k].rotation;
    est.push_back(Rigid3d(rot, -(rot * r.centers[k])));
  }
  const PoseEvaluation e = EvaluatePoses(est, s.cam_from_world, PoseAlignment::kCenters);
  EXPECT_TRUE(e.aligned);
  double worst = 0;
  for (double c : e.center_error) worst = std::max(worst, c);
  return 100 * worst / e.widest_baseline;
}

TEST(TranslationAveraging, ExactDirectionsGiveExactCentersInTheDocumentedGauge) {
  SyntheticSceneOptions o;
  o.num_cameras = 8;
  const SyntheticScene s = MakeSyntheticScene(o);
  const auto r = AverageTranslations(s.graph, TrueRotations(s), {}, TranslationAveragingOptions{});
  EXPECT_EQ(r.root, 0);
  EXPECT_LT(MaxCenterErrorPercent(s, r), 1e-4);
  EXPECT_TRUE(r.centers[0].isZero());
  double mean = 0;
  for (int k = 1; k < 8; ++k) mean += r.centers[k].norm() / 7;
  EXPECT_NEAR(mean, 1.0, 1e-9);
  // The sign: c_j - c_i points along the measured direction, not against it.
  for (size_t k = 0; k < s.graph.edges.size(); ++k) EXPECT_LT(r.edge_error_deg[k], 1e-3);
}

TEST(TranslationAveraging, NoisyAndWrongDirectionsAreAveragedOut) {
  SyntheticSceneOptions o;
  o.num_cameras = 15;
  o.direction_noise_deg = 1.0;
  o.outlier_edge_fraction = 0.1;
  o.seed = 5;
  const SyntheticScene s = MakeSyntheticScene(o);
  // Outlier edges carry a wrong direction here; their rotations are ignored (true rotations given).
  const auto r = AverageTranslations(s.graph, TrueRotations(s), {}, TranslationAveragingOptions{});
  for (bool b : r.solved) EXPECT_TRUE(b);
  EXPECT_LT(MaxCenterErrorPercent(s, r), 2.0);
  for (size_t k = 0; k < s.graph.edges.size(); ++k)
    if (!s.outlier_edge[k]) EXPECT_TRUE(r.edge_inlier[k]) << k << " " << r.edge_error_deg[k];
}

}  // namespace
}  // namespace nerfreg
