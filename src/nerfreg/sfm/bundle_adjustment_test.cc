#include "nerfreg/sfm/bundle_adjustment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/sfm/synthetic_scene_test_util.h"
#include "nerfreg/sfm/triangulation.h"

namespace nerfreg {
namespace {

TEST(Triangulation, DltRecoversAPointAndTheChecksRejectBadTracks) {
  SyntheticSceneOptions o;
  o.num_cameras = 4;
  o.keypoint_noise_px = 0;
  const SyntheticScene s = MakeSyntheticScene(o);
  const std::vector<Track> tracks = BuildTracks(s.graph, {}, TrackOptions{});
  ASSERT_FALSE(tracks.empty());
  const std::vector<bool> posed(4, true);
  int checked = 0;
  for (const Track& t : tracks) {
    SfmPoint p;
    ASSERT_TRUE(TriangulateTrack(t, s.graph.keypoints, s.cameras, s.cam_from_world, posed, TriangulationOptions{}, &p));
    const int id = s.keypoint_point[t.elements[0].image][t.elements[0].keypoint];
    EXPECT_LT((p.x_in_world - s.points[id]).norm(), 1e-6);
    EXPECT_EQ(p.elements.size(), t.elements.size());
    ++checked;
  }
  EXPECT_GT(checked, 100);
  // A track with one wrong keypoint loses that observation and keeps the others.
  Track t = tracks[0];
  ASSERT_GE(t.elements.size(), 3u);
  std::vector<std::vector<Eigen::Vector2d>> moved = s.graph.keypoints;
  moved[t.elements[1].image][t.elements[1].keypoint] += Eigen::Vector2d(25, -10);
  SfmPoint p;
  ASSERT_TRUE(TriangulateTrack(t, moved, s.cameras, s.cam_from_world, posed, TriangulationOptions{}, &p));
  EXPECT_EQ(p.elements.size(), t.elements.size() - 1);
  for (const auto& e : p.elements) EXPECT_NE(e.image, t.elements[1].image);
  // Seen from (almost) one place: the angle check refuses it.
  std::vector<Rigid3d> close = s.cam_from_world;
  for (auto& c : close) c = s.cam_from_world[0];
  TriangulationOptions strict;
  strict.max_reprojection_error_px = 1e9;
  EXPECT_FALSE(TriangulateTrack(tracks[0], s.graph.keypoints, s.cameras, close, posed, strict, &p));
}

// Both linear solvers: the dense Schur complement (up to dense_schur_max_cameras) and the
// iterative one beyond, each from the same perturbed start.
TEST(BundleAdjustment, RecoversPerturbedCamerasAndPointsFromNoisyKeypoints) {
  for (const int dense_schur_max_cameras : {50, 0}) {
    SCOPED_TRACE(dense_schur_max_cameras == 0 ? "iterative Schur" : "dense Schur");
    SyntheticSceneOptions o;
    o.num_cameras = 8;
    o.num_points = 300;
    o.keypoint_noise_px = 0.5;
    const SyntheticScene s = MakeSyntheticScene(o);
    const std::vector<Track> tracks = BuildTracks(s.graph, {}, TrackOptions{});
    std::mt19937 rng(7);
    std::normal_distribution<double> g(0.0, 1.0);
    std::vector<Rigid3d> poses = s.cam_from_world;
    for (size_t k = 1; k < poses.size(); ++k) {  // camera 0 is the fixed gauge
      poses[k] = Rigid3d(SmallRotation(rng, 1.0) * poses[k].rotation,
                         poses[k].translation + 0.05 * Eigen::Vector3d(g(rng), g(rng), g(rng)));
    }
    std::vector<SfmPoint> points;
    for (const Track& t : tracks) {
      const int id = s.keypoint_point[t.elements[0].image][t.elements[0].keypoint];
      points.push_back({s.points[id] + 0.05 * Eigen::Vector3d(g(rng), g(rng), g(rng)), t.elements});
    }
    const std::vector<bool> posed(poses.size(), true);
    BundleAdjustmentOptions options;
    options.dense_schur_max_cameras = dense_schur_max_cameras;
    const auto summary = BundleAdjust(s.cameras, s.graph.keypoints, posed, 0, &poses, &points, options);
    EXPECT_GT(summary.initial_rms_px, 3.0);
    // The residual of 2D noise sigma 0.5 px is ~0.5 * sqrt(2) px rms, a little less after fitting.
    EXPECT_LT(summary.final_rms_px, 0.75);
    EXPECT_GT(summary.final_rms_px, 0.4);
    // Rotations aligned on rotations: a centre-only fit would add its own rotation error of about
    // (centre error / spread). Measured: median 0.07 deg (0.5 px noise, a camera sees its points under
    // ~28 deg, so its rotation and translation trade off), centres 0.0045 of a ~8 baseline.
    const PoseEvaluation e = EvaluatePoses(poses, s.cam_from_world, PoseAlignment::kRotationsAndCenters);
    ASSERT_TRUE(e.aligned);
    EXPECT_LT(e.median_rotation_deg, 0.12);
    for (double r : e.rotation_error_deg) EXPECT_LT(r, 0.25);
    for (double c : e.center_error) EXPECT_LT(c / e.widest_baseline, 0.003);
  }
}

TEST(BundleAdjustment, SpreadPointSubsetCoversEveryCellLongestTracksFirst) {
  // Two 100x100 images cut into 2x2 cells, one point per cell: the long track in the top-left cells
  // is taken, the short ones in the same cells are not, the one alone in a cell is, and an
  // observation in an unposed image fills nothing.
  const std::vector<Camera> cameras(3, Camera::Pinhole(100, 100, 100, 100, 50, 50));
  std::vector<std::vector<Eigen::Vector2d>> keypoints(3);
  auto add = [&](int image, double x, double y) {
    keypoints[image].push_back({x, y});
    return TrackElement{image, static_cast<int>(keypoints[image].size()) - 1};
  };
  std::vector<SfmPoint> points(5);
  points[0].elements = {add(0, 10, 10), add(1, 12, 11)};                  // short, top-left in both
  points[1].elements = {add(0, 20, 20), add(1, 22, 21), add(2, 30, 30)};  // long, top-left in both
  points[2].elements = {add(0, 80, 80), add(1, 81, 82)};                  // bottom-right in both
  points[3].elements = {add(0, 85, 85), add(2, 10, 90)};                  // bottom-right in 0, taken there already
  points[4].elements = {add(1, 90, 10), add(2, 90, 10)};                  // top-right in 1: a free cell
  const std::vector<bool> posed = {true, true, false};
  EXPECT_EQ(SpreadPointSubset(points, keypoints, cameras, posed, 2, 1), (std::vector<int>{1, 2, 4}));
  // Two per cell: the short top-left track joins; one cell per image keeps everything.
  EXPECT_EQ(SpreadPointSubset(points, keypoints, cameras, posed, 2, 2), (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(SpreadPointSubset(points, keypoints, cameras, posed, 1, 1), (std::vector<int>{1}));
  EXPECT_THROW(SpreadPointSubset(points, keypoints, cameras, posed, 0, 1), std::invalid_argument);
}

// Self-calibration's focal standard deviation on two captures (12 cameras) of 500 points, each adjusted
// from a focal 5 % off with exact poses and points and 0.5 px noise: cameras on a cap, each
// aimed at its own point with its own roll, pin the focal down; cameras that only translate (one
// orientation) leave it free (stretching depths by a and the focal by a reprojects the same).
BundleAdjustmentSummary SelfCalibrate(bool translation_only, double* focal_px) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::vector<Eigen::Vector3d> world(500);
  for (auto& x : world) x = Eigen::Vector3d(1.5 * u(rng), 1.5 * u(rng), u(rng));
  const Camera truth = Camera::Pinhole(320, 240, 280, 280, 160, 120);
  std::vector<Rigid3d> poses;
  for (int c = 0; c < 12; ++c) {
    const double az = M_PI * u(rng), el = 0.6 * std::abs(u(rng));
    const Eigen::Vector3d centre = translation_only ? Eigen::Vector3d(1.5 * u(rng), -6.0 + 0.5 * u(rng), 1.5 * u(rng))
                                                    : 6.0 * Eigen::Vector3d(std::sin(el) * std::cos(az), -std::cos(el),
                                                                            std::sin(el) * std::sin(az));
    Rigid3d pose = SyntheticLookAt(
        translation_only ? Eigen::Vector3d(0, -6.0, 0) : centre,
        translation_only ? Eigen::Vector3d::Zero() : Eigen::Vector3d(0.5 * u(rng), 0.5 * u(rng), 0.5 * u(rng)));
    if (!translation_only)
      pose =
          Rigid3d(Eigen::AngleAxisd(0.5 * u(rng), Eigen::Vector3d::UnitZ()) * pose.rotation, Eigen::Vector3d::Zero());
    pose.translation = -(pose.rotation * centre);
    poses.push_back(pose);
  }
  std::vector<std::vector<Eigen::Vector2d>> keypoints(poses.size());
  std::vector<SfmPoint> points;
  for (const Eigen::Vector3d& x : world) {
    SfmPoint point{x, {}};
    for (size_t c = 0; c < poses.size(); ++c) {
      const Eigen::Vector3d xc = poses[c] * x;
      const Eigen::Vector2d uv = truth.ImgFromCam(xc) + Eigen::Vector2d(noise(rng), noise(rng));
      if (xc.z() <= 0 || uv.x() < 0 || uv.y() < 0 || uv.x() >= truth.width || uv.y() >= truth.height) continue;
      keypoints[c].push_back(uv);
      point.elements.push_back({static_cast<int>(c), static_cast<int>(keypoints[c].size()) - 1});
    }
    if (point.elements.size() >= 2) points.push_back(point);
  }
  std::vector<Camera> cameras(poses.size(), Camera::Pinhole(320, 240, 294, 294, 160, 120));
  BundleAdjustmentOptions options;
  options.refine_focal = true;
  options.estimate_focal_stddev = true;
  const auto summary = BundleAdjust(&cameras, std::vector<int>(poses.size(), 0), keypoints,
                                    std::vector<bool>(poses.size(), true), 0, &poses, &points, options);
  *focal_px = cameras[0].fx;
  return summary;
}

TEST(BundleAdjustment, FocalStddevIsSmallForAGeneralMotionAndLargeForPureTranslation) {
  double focal = 0;
  const BundleAdjustmentSummary general = SelfCalibrate(false, &focal);
  ASSERT_EQ(general.focal_stddev_px.size(), 1u);
  const double sd = general.focal_stddev_px.at(0);
  RecordProperty("general_focal_stddev_px", std::to_string(sd));
  EXPECT_GT(sd, 0.0);
  EXPECT_LT(sd, 0.01 * 280) << "focal " << focal;
  EXPECT_LT(std::abs(focal - 280), 4 * sd + 0.1);  // the truth within the stated uncertainty
  const BundleAdjustmentSummary translating = SelfCalibrate(true, &focal);
  ASSERT_EQ(translating.focal_stddev_px.size(), 1u);
  RecordProperty("translating_focal_stddev_px", std::to_string(translating.focal_stddev_px.at(0)));
  EXPECT_GT(translating.focal_stddev_px.at(0), 0.05 * 280);  // infinity where singular
}

}  // namespace
}  // namespace nerfreg
