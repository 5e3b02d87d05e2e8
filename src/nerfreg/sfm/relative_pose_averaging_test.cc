#include "nerfreg/sfm/relative_pose_averaging.h"

#include <gtest/gtest.h>

#include <random>

#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/sfm/synthetic_scene_test_util.h"

namespace nerfreg {
namespace {

// Cameras in two rows on a sphere of radius 4, looking at points near its centre (well spread:
// directions alone fix the centres only up to a drift along a nearly straight chain).
std::vector<Rigid3d> CapCameras(int n) {
  std::vector<Rigid3d> out;
  const int columns = (n + 1) / 2;
  for (int k = 0; k < n; ++k) {
    const double a = -0.9 + 1.8 * (k / 2) / std::max(1, columns - 1), b = k % 2 == 0 ? -0.35 : 0.35;
    const Eigen::Vector3d c(4 * std::sin(a) * std::cos(b), -4 * std::cos(a) * std::cos(b), 4 * std::sin(b));
    out.push_back(SyntheticLookAt(c, Eigen::Vector3d(0.2 * std::cos(2 * a), 0, 0.1 * k / n)));
  }
  return out;
}

// Every pair of cameras less than `max_distance` apart, in both directions; each measurement's
// rotation and translation direction perturbed by a random rotation of about `noise_deg` (RMS
// angle), independently per direction.
std::vector<RelativePose> NoisyEdges(const std::vector<Rigid3d>& cams, double max_distance, double noise_deg,
                                     unsigned seed) {
  std::mt19937 rng(seed);
  const double per_axis = noise_deg / std::sqrt(3.0);
  std::vector<RelativePose> edges;
  const int n = static_cast<int>(cams.size());
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      if ((cams[i].Inverse().translation - cams[j].Inverse().translation).norm() > max_distance) continue;
      for (const auto& [a, b] : {std::pair<int, int>{i, j}, std::pair<int, int>{j, i}}) {
        RelativePose r;
        r.i = a;
        r.j = b;
        const Rigid3d truth = cams[b] * cams[a].Inverse();
        r.j_from_i.rotation = SmallRotation(rng, per_axis) * truth.rotation;
        // An arbitrary length: the solver uses directions only.
        r.j_from_i.translation = 3.7 * (SmallRotation(rng, per_axis) * truth.translation.normalized());
        edges.push_back(r);
      }
    }
  return edges;
}

PoseEvaluation Evaluate(const RelativePoseAveragingResult& r, const std::vector<Rigid3d>& truth) {
  for (size_t k = 0; k < truth.size(); ++k) EXPECT_TRUE(r.posed[k]) << k;
  const PoseEvaluation e = EvaluatePoses(r.cam_from_world, truth, PoseAlignment::kRotationsAndCenters);
  EXPECT_TRUE(e.aligned);
  return e;
}

double Max(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }

TEST(RelativePoseAveraging, ExactRelativePosesGiveExactCamerasInTheClassicalFrame) {
  const std::vector<Rigid3d> truth = CapCameras(10);
  const auto r = GlobalPosesFromRelativePoses(10, NoisyEdges(truth, 3.5, 0.0, 1), {});
  const PoseEvaluation e = Evaluate(r, truth);
  EXPECT_LT(Max(e.rotation_error_deg), 1e-4);
  EXPECT_LT(Max(e.center_error) / e.widest_baseline, 1e-5);
  // The frame: camera 0 at the identity, mean distance of the others to it 1.
  EXPECT_LT(r.cam_from_world[0].translation.norm(), 1e-12);
  EXPECT_LT(RotationErrorDeg(r.cam_from_world[0].rotation, Eigen::Quaterniond::Identity()), 1e-9);
  double mean = 0;
  for (int k = 1; k < 10; ++k) mean += r.cam_from_world[k].Inverse().translation.norm() / 9;
  EXPECT_NEAR(mean, 1.0, 1e-6);
  for (bool b : r.edge_inlier) EXPECT_TRUE(b);
}

TEST(RelativePoseAveraging, RecoversCamerasFromRelativePosesWithOneDegreeOfNoise) {
  const std::vector<Rigid3d> truth = CapCameras(10);
  const auto r = GlobalPosesFromRelativePoses(10, NoisyEdges(truth, 3.5, 1.0, 7), {});
  const PoseEvaluation e = Evaluate(r, truth);
  // Averaging over ~6 edges per camera brings the 1 deg edge noise below it.
  EXPECT_LT(Max(e.rotation_error_deg), 1.0);
  EXPECT_LT(100 * Max(e.center_error) / e.widest_baseline, 3.0);
  for (double d : r.edge_rotation_error_deg) EXPECT_LT(d, 4.0);
}

TEST(RelativePoseAveraging, AWrongEdgeIsOutvotedAndReported) {
  const std::vector<Rigid3d> truth = CapCameras(10);
  std::vector<RelativePose> edges = NoisyEdges(truth, 3.5, 1.0, 3);
  // The measurement 2 -> 4: 60 deg off and pointing backwards.
  size_t wrong = edges.size();
  for (size_t k = 0; k < edges.size(); ++k)
    if (edges[k].i == 2 && edges[k].j == 4) wrong = k;
  ASSERT_LT(wrong, edges.size());
  edges[wrong].j_from_i.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 3, Eigen::Vector3d(1, 2, 0).normalized())) *
      edges[wrong].j_from_i.rotation;
  edges[wrong].j_from_i.translation = -edges[wrong].j_from_i.translation;
  const auto r = GlobalPosesFromRelativePoses(10, edges, {});
  const PoseEvaluation e = Evaluate(r, truth);
  EXPECT_LT(Max(e.rotation_error_deg), 1.0);
  EXPECT_LT(100 * Max(e.center_error) / e.widest_baseline, 3.0);
  EXPECT_FALSE(r.edge_inlier[wrong]);
  EXPECT_GT(r.edge_rotation_error_deg[wrong], 45.0);
  for (size_t k = 0; k < edges.size(); ++k)
    if (k != wrong) EXPECT_TRUE(r.edge_inlier[k]) << k;
}

TEST(RelativePoseAveraging, ImagesWithoutEdgesOrWithRotationOnlyEdgesAreNotPosed) {
  const std::vector<Rigid3d> truth = CapCameras(6);
  std::vector<RelativePose> edges = NoisyEdges(truth, 3.5, 0.0, 1);
  // Image 6 has no edge; image 7 only a zero-length translation (no direction) to image 0.
  RelativePose rot_only;
  rot_only.i = 0;
  rot_only.j = 7;
  edges.push_back(rot_only);
  const auto r = GlobalPosesFromRelativePoses(8, edges, {});
  for (int k = 0; k < 6; ++k) EXPECT_TRUE(r.posed[k]);
  EXPECT_FALSE(r.posed[6]);
  EXPECT_FALSE(r.posed[7]);
  EXPECT_FALSE(r.edge_inlier.back());
  EXPECT_THROW(GlobalPosesFromRelativePoses(3, {RelativePose{0, 3, Rigid3d(), 1.0}}, {}), std::invalid_argument);
  EXPECT_THROW(GlobalPosesFromRelativePoses(3, {RelativePose{1, 1, Rigid3d(), 1.0}}, {}), std::invalid_argument);
  EXPECT_THROW(GlobalPosesFromRelativePoses(3, {RelativePose{0, 1, Rigid3d(), 0.0}}, {}), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
