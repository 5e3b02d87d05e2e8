#include "nerfreg/sfm/global_sfm.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "nerfreg/geometry/conventions.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/raycaster.h"
#include "nerfreg/render/renderer.h"
#include "nerfreg/render/trajectory.h"
#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/sfm/synthetic_scene_test_util.h"
#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

// 12 cameras, 400 points, 0.5 px keypoint noise, two-view estimates 0.5 deg / 2 deg off, a
// fraction of the edges wrong and 10 % wrong matches on every edge.
SyntheticScene NoisyScene(double outlier_edge_fraction, unsigned seed) {
  SyntheticSceneOptions o;
  o.num_cameras = 12;
  o.num_points = 400;
  o.keypoint_noise_px = 0.5;
  o.rotation_noise_deg = 0.5;
  o.direction_noise_deg = 2.0;
  o.outlier_edge_fraction = outlier_edge_fraction;
  o.outlier_match_fraction = 0.1;
  o.seed = seed;
  return MakeSyntheticScene(o);
}

TEST(GlobalSfm, SyntheticCorrespondencesWithWrongEdgesAndMatchesGiveTheTrueCameras) {
  SyntheticScene s = NoisyScene(0.1, 11);
  // An image with no edge is reported by name and left out.
  s.graph.names.push_back("lonely.png");
  s.graph.keypoints.emplace_back();
  s.cameras.push_back(s.cameras[0]);
  const SfmResult r = RunGlobalSfm(s.graph, s.cameras, SfmOptions{});
  ASSERT_EQ(r.posed.size(), 13u);
  EXPECT_FALSE(r.posed[12]);
  EXPECT_EQ(r.not_posed, std::vector<std::string>{"lonely.png"});
  std::vector<Rigid3d> est(r.cam_from_world.begin(), r.cam_from_world.begin() + 12);
  for (int k = 0; k < 12; ++k) EXPECT_TRUE(r.posed[k]);
  // Centres after Umeyama on centres; rotations after the fit on rotations (a centre-only fit adds
  // its own rotation error, ~ centre error / spread). Measured: rotations median 0.095, max 0.14 deg;
  // centres median 0.11 % of the widest baseline (0.5 px keypoint noise, as the BA test).
  const PoseEvaluation e = EvaluatePoses(est, s.cam_from_world, PoseAlignment::kCenters);
  const PoseEvaluation er = EvaluatePoses(est, s.cam_from_world, PoseAlignment::kRotationsAndCenters);
  ASSERT_TRUE(e.aligned && er.aligned);
  std::printf("synthetic: rotation median %.4f max %.4f deg, centre median %.4f %% of %.3f\n", er.median_rotation_deg,
              *std::max_element(er.rotation_error_deg.begin(), er.rotation_error_deg.end()), e.median_center_percent,
              e.widest_baseline);
  EXPECT_LT(er.median_rotation_deg, 0.15);
  for (double d : er.rotation_error_deg) EXPECT_LT(d, 0.25);
  for (double c : e.center_error) EXPECT_LT(c / e.widest_baseline, 0.005);
  EXPECT_GT(r.num_points, 300);
  EXPECT_LT(r.mean_reprojection_error_px, 0.8);
  EXPECT_EQ(r.degenerate, "");  // the centres agree with the right edges' directions
  // The frame: camera 0 at the identity, mean distance of the others to it 1.
  EXPECT_LT(RotationErrorDeg(r.cam_from_world[0].rotation, Eigen::Quaterniond::Identity()), 1e-9);
  EXPECT_LT(r.cam_from_world[0].translation.norm(), 1e-9);
  double mean = 0;
  for (int k = 1; k < 12; ++k) mean += SyntheticCenter(r.cam_from_world[k]).norm() / 11;
  EXPECT_NEAR(mean, 1.0, 1e-9);
  // Wrong matches do not survive as observations.
  for (const SfmPoint& p : r.points) {
    const int id = s.keypoint_point[p.elements[0].image][p.elements[0].keypoint];
    for (const auto& el : p.elements) EXPECT_EQ(s.keypoint_point[el.image][el.keypoint], id);
  }
}

// Cameras with these centres and the true rotations of `s`: a solution to test against the edges.
std::vector<Rigid3d> WithCentres(const SyntheticScene& s, const std::vector<Eigen::Vector3d>& centres) {
  std::vector<Rigid3d> out;
  for (size_t k = 0; k < centres.size(); ++k) {
    const Eigen::Quaterniond& r = s.cam_from_world[k].rotation;
    out.push_back(Rigid3d(r, -(r * centres[k])));
  }
  return out;
}

// The centres of a wrong solution on a line (or reflected through the scene) while the edges'
// two-view directions point across it: contradicted. The true cameras are not, and neither is a
// capture along a rail, whose centres are on a line with the pairs' directions along it.
TEST(GlobalSfm, CentresContradictingTheTwoViewDirectionsAreFoundAndARailCaptureIsNot) {
  const SyntheticScene s = NoisyScene(0.1, 11);
  const int n = static_cast<int>(s.cam_from_world.size());
  const std::vector<bool> posed(n, true);
  const EdgeDirectionCheck truth = CheckEdgeDirections(s.cam_from_world, posed, s.graph, {}, 40.0);
  EXPECT_FALSE(truth.contradicted);
  EXPECT_LT(truth.median_residual_deg, 5.0);  // 2 deg direction noise, 10 % wrong edges
  EXPECT_GT(truth.off_line_fraction, 0.2);    // a cap, not a line
  EXPECT_EQ(truth.num_edges, static_cast<int>(s.graph.edges.size()));

  // Collapsed onto a line through the scene's centre (the line along x, in the order of the images).
  std::vector<Eigen::Vector3d> on_line, reflected;
  for (int k = 0; k < n; ++k) {
    on_line.push_back(Eigen::Vector3d(0.5 * k - 3.0, -6.0, 0.0));
    reflected.push_back(-SyntheticCenter(s.cam_from_world[k]));
  }
  const EdgeDirectionCheck line = CheckEdgeDirections(WithCentres(s, on_line), posed, s.graph, {}, 40.0);
  std::printf("collinear collapse: %.1f deg over %d edges, off the line %.3g\n", line.median_residual_deg,
              line.num_edges, line.off_line_fraction);
  EXPECT_TRUE(line.contradicted);
  EXPECT_LT(line.off_line_fraction, 1e-9);
  const EdgeDirectionCheck mirror = CheckEdgeDirections(WithCentres(s, reflected), posed, s.graph, {}, 40.0);
  EXPECT_TRUE(mirror.contradicted);
  EXPECT_GT(mirror.median_residual_deg, 150.0);
  // Only the edges asked for are measured; with fewer than 3 nothing is contradicted.
  std::vector<bool> two(s.graph.edges.size(), false);
  two[0] = two[1] = true;
  const EdgeDirectionCheck few = CheckEdgeDirections(WithCentres(s, on_line), posed, s.graph, two, 40.0);
  EXPECT_EQ(few.num_edges, 2);
  EXPECT_FALSE(few.contradicted);

  // A rail: 8 cameras 0.3 apart along x, looking ahead (+y) at the scene; edges from the true poses
  // with 2 deg direction noise.
  ViewGraph rail;
  std::vector<Rigid3d> rail_cams;
  std::mt19937 rng(3);
  for (int k = 0; k < 8; ++k)
    rail_cams.push_back(SyntheticLookAt(Eigen::Vector3d(0.3 * k, -6.0, 0.0), Eigen::Vector3d(0.3 * k, 0.0, 0.0)));
  for (int i = 0; i < 8; ++i)
    for (int j = i + 1; j < 8; ++j) {
      ViewGraphEdge e;
      e.i = i, e.j = j;
      const Rigid3d j_from_i = rail_cams[j] * rail_cams[i].Inverse();
      e.j_from_i = Rigid3d(j_from_i.rotation, SmallRotation(rng, 2.0) * j_from_i.translation.normalized());
      rail.edges.push_back(e);
    }
  const EdgeDirectionCheck on_rail = CheckEdgeDirections(rail_cams, std::vector<bool>(8, true), rail, {}, 40.0);
  EXPECT_LT(on_rail.off_line_fraction, 1e-9);
  EXPECT_FALSE(on_rail.contradicted);
  EXPECT_LT(on_rail.median_residual_deg, 5.0);
  // The rail's centres in reverse order along the same line: the edges now point the other way.
  std::vector<Rigid3d> reversed;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c(0.3 * (7 - k), -6.0, 0.0);
    reversed.push_back(Rigid3d(rail_cams[k].rotation, -(rail_cams[k].rotation * c)));
  }
  EXPECT_TRUE(CheckEdgeDirections(reversed, std::vector<bool>(8, true), rail, {}, 40.0).contradicted);
}

// Edges whose two-view geometry is wrong (rotation averaging leaves them out) often still hold
// right matches (low-texture photos: 430 of 745 edges of the Castle-simu set). Once the poses are
// solved, those matches are checked against them and join the tracks: here half the points are
// matched only across wrong edges, and become points; the wrong matches still do not survive.
TEST(GlobalSfm, MatchesOfEdgesLeftOutByRotationAveragingJoinTheTracksOnceThePosesAgree) {
  SyntheticScene s = NoisyScene(0.5, 5);
  // Half the points are matched only across the wrong edges.
  for (size_t e = 0; e < s.graph.edges.size(); ++e) {
    if (s.outlier_edge[e]) continue;
    ViewGraphEdge& edge = s.graph.edges[e];
    std::vector<std::pair<int, int>> kept;
    for (const auto& [a, b] : edge.inlier_matches)
      if (s.keypoint_point[edge.i][a] % 2 != 0) kept.push_back({a, b});
    edge.inlier_matches = kept;
  }
  SfmOptions first_tracks_only;
  first_tracks_only.reverify_matches_px = 0;
  const SfmResult before = RunGlobalSfm(s.graph, s.cameras, first_tracks_only);
  const SfmResult after = RunGlobalSfm(s.graph, s.cameras, SfmOptions{});
  auto observations = [](const SfmResult& r) {
    int count = 0;
    for (const SfmPoint& p : r.points) count += static_cast<int>(p.elements.size());
    return count;
  };
  int left_out = 0;
  for (bool outlier : s.outlier_edge) left_out += outlier;
  const PoseEvaluation e_before =
      EvaluatePoses(before.cam_from_world, s.cam_from_world, PoseAlignment::kRotationsAndCenters);
  const PoseEvaluation e_after =
      EvaluatePoses(after.cam_from_world, s.cam_from_world, PoseAlignment::kRotationsAndCenters);
  ASSERT_TRUE(e_before.aligned && e_after.aligned);
  std::printf("%d of %zu edges wrong; observations %d -> %d, points %d -> %d; rotation median %.4f -> %.4f deg\n",
              left_out, s.graph.edges.size(), observations(before), observations(after), before.num_points,
              after.num_points, e_before.median_rotation_deg, e_after.median_rotation_deg);
  EXPECT_GT(after.num_points, 1.5 * before.num_points);
  EXPECT_GT(observations(after), 1.5 * observations(before));
  EXPECT_LT(e_after.median_rotation_deg, 0.15);
  for (const SfmPoint& p : after.points) {
    const int id = s.keypoint_point[p.elements[0].image][p.elements[0].keypoint];
    for (const auto& el : p.elements) EXPECT_EQ(s.keypoint_point[el.image][el.keypoint], id);
  }
}

struct RenderedViews {
  std::vector<Image> images;
  std::vector<Camera> cameras;
  std::vector<Rigid3d> cam_from_world;
  std::vector<std::string> names;
};

// A procedural forward-facing scene rendered like `nerfreg render --trajectory forward`
// (8-bit quantised, as the PNGs are).
RenderedViews RenderForward(unsigned seed, int views, int width = 128, int height = 96, double k1 = 0,
                            double spread = 0.35) {
  const TriangleMesh mesh = ProceduralForwardScene(seed);
  RayCaster caster(mesh);
  ForwardOptions fo;
  fo.num_views = views;
  fo.width = width;
  fo.height = height;
  fo.spread = spread;
  RenderedViews out;
  for (PosedCamera pc : ForwardTrajectory(fo)) {
    pc.camera.k1 = k1;
    Image im = CompositeOver(RenderView(caster, mesh, pc.camera, pc.cam_from_world, RenderOptions{}).rgba, 0, 0, 0);
    for (float& v : im.data) v = std::round(std::clamp(v, 0.f, 1.f) * 255.f) / 255.f;
    out.images.push_back(std::move(im));
    out.cameras.push_back(pc.camera);
    out.cam_from_world.push_back(pc.cam_from_world);
    out.names.push_back("r_" + std::to_string(out.names.size()) + ".png");
  }
  return out;
}

TEST(GlobalSfm, PosesEveryRenderedForwardFacingView) {
  const RenderedViews v = RenderForward(7, 10);
  const SfmResult r = PoseImages(v.images, v.cameras, v.names, SfmOptions{});
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(r.posed[k]) << v.names[k];
  const PoseEvaluation e = EvaluatePoses(r.cam_from_world, v.cam_from_world, PoseAlignment::kCenters);
  const PoseEvaluation er = EvaluatePoses(r.cam_from_world, v.cam_from_world, PoseAlignment::kRotationsAndCenters);
  ASSERT_TRUE(e.aligned && er.aligned);
  std::printf(
      "10 views: median rotation %.4f deg (Umeyama on centres: %.4f), median centre %.3f %% of %.3f, %d points, %.3f "
      "px\n",
      er.median_rotation_deg, e.median_rotation_deg, e.median_center_percent, e.widest_baseline, r.num_points,
      r.mean_reprojection_error_px);
  // Measured (seed 7): 0.035 deg, 0.21 % of the baseline, 0.18 px. Rotations are compared after
  // the fit on rotations: with centres this close (a 0.63 spread, 0.0013 error) a centre-only
  // Umeyama fit is itself off by ~0.5 deg (printed above, not asserted).
  EXPECT_LT(er.median_rotation_deg, 0.5);
  EXPECT_LT(e.median_center_percent, 2.0);
  EXPECT_LT(r.mean_reprojection_error_px, 1.0);
}

TEST(GlobalSfm, PosesThreeViews) {
  const RenderedViews v = RenderForward(3, 3);
  // RANSAC's two-view geometry, as measured below. With USAC (the default) these views give
  // 0.18 deg and 3.50 % of the baseline: three views carry little redundancy.
  SfmOptions options;
  options.view_graph.estimator = TwoViewEstimator::kRansac;
  const SfmResult r = PoseImages(v.images, v.cameras, v.names, options);
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(r.posed[k]) << v.names[k];
  // Three centres: align on rotations and centres (a centre-only fit of 3 points is exact).
  const PoseEvaluation e = EvaluatePoses(r.cam_from_world, v.cam_from_world, PoseAlignment::kRotationsAndCenters);
  ASSERT_TRUE(e.aligned);
  std::printf("3 views: median rotation %.4f deg, median centre %.3f %% of %.3f\n", e.median_rotation_deg,
              e.median_center_percent, e.widest_baseline);
  // Measured (seed 3): 0.25 deg, 2.3 % of a 0.245 baseline: three views carry little redundancy.
  EXPECT_LT(e.median_rotation_deg, 0.5);
  EXPECT_LT(e.median_center_percent, 3.5);
}

// Photos without a calibration file: from a focal prior 1.2 x the longer side (COLMAP's, 9 % off
// here) and no distortion, the bundle adjustment recovers the focal length and the lens's radial
// distortion (k1 and k2 trade against each other, so the distortion is compared where it is
// largest, at the image corner). A spiral twice the default's width: the focal length of
// forward-facing views with a narrow baseline trades against their depth.
// Self-calibrated, the view graph measured its edges with the prior intrinsics (here 25 % off, the
// edges' rotations 6 deg off); measured again with the refined ones they agree with the cameras,
// and the graph says which intrinsics they were measured with. Edges whose intrinsics did not
// change stay as they are, and so does a panoramic edge (it has no translation to refine).
TEST(GlobalSfm, EdgesAreMeasuredAgainWithTheRefinedIntrinsics) {
  const int n = 3;
  std::vector<Rigid3d> cam_from_world;
  for (int k = 0; k < n; ++k)
    cam_from_world.push_back(LookAt({4 * std::sin(0.2 * k), 0.3 * k, -4 * std::cos(0.2 * k)}, {0, 0, 0}, {0, -1, 0}));
  const std::vector<Camera> refined(n, Camera::Pinhole(64, 48, 60, 60, 32, 24));
  ViewGraph graph;
  graph.keypoints.resize(n);
  for (int p = 0; p < 60; ++p) {
    const Eigen::Vector3d x(std::sin(1.7 * p), std::cos(2.3 * p), 0.8 * std::sin(0.9 * p + 1));
    for (int k = 0; k < n; ++k) graph.keypoints[k].push_back(refined[k].ImgFromCam(cam_from_world[k] * x));
  }
  const Eigen::Quaterniond bias(Eigen::AngleAxisd(6 * M_PI / 180, Eigen::Vector3d(0.3, 1, 0.2).normalized()));
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      ViewGraphEdge e;
      e.i = i, e.j = j;
      const Rigid3d j_from_i = cam_from_world[j] * cam_from_world[i].Inverse();
      e.j_from_i = Rigid3d(bias * j_from_i.rotation, j_from_i.translation.normalized());
      for (int p = 0; p < 60; ++p) e.inlier_matches.push_back({p, p});
      graph.edges.push_back(e);
    }
  }
  graph.edges[2].panoramic = true;
  const auto error_deg = [&](const ViewGraph& g, int q) {
    const ViewGraphEdge& e = g.edges[q];
    return RotationErrorDeg(e.j_from_i.rotation, (cam_from_world[e.j] * cam_from_world[e.i].Inverse()).rotation);
  };
  ViewGraph same = graph;
  same.cameras = refined;  // measured with these already: nothing to do
  MeasureEdgesWithIntrinsics(refined, &same);
  for (int q = 0; q < 3; ++q) EXPECT_NEAR(error_deg(same, q), 6.0, 1e-9);
  graph.cameras.assign(n, Camera::Pinhole(64, 48, 75, 75, 32, 24));  // a prior 25 % off
  MeasureEdgesWithIntrinsics(refined, &graph);
  for (int q = 0; q < 2; ++q) {
    EXPECT_LT(error_deg(graph, q), 0.05) << q;
    const ViewGraphEdge& e = graph.edges[q];
    const Eigen::Vector3d direction = (cam_from_world[e.j] * cam_from_world[e.i].Inverse()).translation.normalized();
    EXPECT_GT(e.j_from_i.translation.dot(direction), std::cos(0.5 * M_PI / 180)) << q;
  }
  EXPECT_NEAR(error_deg(graph, 2), 6.0, 1e-9);  // panoramic: left
  EXPECT_TRUE(graph.cameras == refined);
  ViewGraph wrong = graph;
  wrong.cameras.pop_back();
  EXPECT_THROW(MeasureEdgesWithIntrinsics(refined, &wrong), std::invalid_argument);
}

TEST(GlobalSfm, SelfCalibrationRecoversTheFocalLengthAndDistortionOfRenderedViews) {
  const RenderedViews v = RenderForward(7, 12, 320, 240, -0.08, 0.8);
  const Camera truth = v.cameras[0];
  std::vector<Camera> prior;
  for (const Camera& c : v.cameras) prior.push_back(Camera::Pinhole(c.width, c.height, 384, 384, 160, 120));
  SfmOptions o;
  o.view_graph.estimate_focal = true;
  o.refine_focal = o.refine_distortion = true;
  const SfmResult r = PoseImages(v.images, prior, v.names, o);
  for (int k = 0; k < 12; ++k) ASSERT_TRUE(r.posed[k]) << v.names[k];
  const Camera& c = r.cameras[0];
  auto radial = [](const Camera& cam) {
    const double r2 = (cam.cx * cam.cx + cam.cy * cam.cy) / (cam.fx * cam.fx);  // the corner
    return 1 + r2 * (cam.k1 + r2 * cam.k2);
  };
  std::printf("self-calibration: focal %.2f (truth %.2f, prior 384) k1 %.4f k2 %.4f (truth %.3f), corner %.4f (%.4f)\n",
              c.fx, truth.fx, c.k1, c.k2, truth.k1, radial(c), radial(truth));
  // Measured with keypoint refinement (the default): 353.82 px (0.5 % off) with GCC, corner factor
  // 0.9739 against 0.9742, rotations 0.030 deg; on the sanitized clang build's renders (procedural
  // renders differ between the two compilers) 343.09 px (2.5 %), 0.9698 and 0.103 deg, where
  // without the refinement they give 354.09 px and 0.047 deg. The focal length is weakly determined
  // by these 12 views (k2 ends between -0.033 and 0.072 in these runs, the corner factor within
  // 0.970-0.974), so the bound is 3 %, as for the subset below.
  EXPECT_NEAR(c.fx, truth.fx, 0.03 * truth.fx);
  EXPECT_NEAR(radial(c), radial(truth), 0.01);
  for (const Camera& other : r.cameras) EXPECT_EQ(other.fx, c.fx);  // one camera group
  const PoseEvaluation e = EvaluatePoses(r.cam_from_world, v.cam_from_world, PoseAlignment::kRotationsAndCenters);
  ASSERT_TRUE(e.aligned);
  std::printf("self-calibration: median rotation %.4f deg\n", e.median_rotation_deg);
  EXPECT_LT(e.median_rotation_deg, 0.2);
  // The same graph with the rounds before the last on a few points per image (2 x 2 cells, 2 a
  // cell): the last round's adjustment of every point still finds the focal length. Measured with
  // keypoint refinement: 353.85 px with GCC, 347.48 (1.3 %) on the sanitized clang build's renders.
  SfmOptions few = o;
  few.subset_cells = 2;
  few.subset_per_cell = 2;
  // (From the prior focal: the graph's cameras are the refined ones now, its edges measured with them.)
  EXPECT_TRUE(r.view_graph.cameras == r.cameras);
  const SfmResult f = RunGlobalSfm(r.view_graph, prior, few);
  std::printf("self-calibration on a subset first: focal %.2f, %d points\n", f.cameras[0].fx, f.num_points);
  EXPECT_NEAR(f.cameras[0].fx, truth.fx, 0.03 * truth.fx);
  EXPECT_NEAR(radial(f.cameras[0]), radial(truth), 0.01);
  const PoseEvaluation ef = EvaluatePoses(f.cam_from_world, v.cam_from_world, PoseAlignment::kRotationsAndCenters);
  ASSERT_TRUE(ef.aligned);
  EXPECT_LT(ef.median_rotation_deg, 0.2);
}

// SfmOptions::focal_starts: the solve from each multiple of the prior focal, the one whose points
// keep the most observations returned, exactly as that start alone gives it. A prior half the
// truth: both starts find the focal here (measured with GCC: 349.59 px and 2613 observations from
// x1, 349.74 px and 2636 from x2, truth 352), the second explaining a few more observations.
TEST(GlobalSfm, FocalStartsReturnTheStartWhosePointsKeepTheMostObservations) {
  const RenderedViews v = RenderForward(7, 12, 320, 240, -0.08, 0.8);
  const double truth = v.cameras[0].fx;
  std::vector<Camera> prior;
  for (const Camera& c : v.cameras)
    prior.push_back(Camera::Pinhole(c.width, c.height, truth / 2, truth / 2, 0.5 * c.width, 0.5 * c.height));
  SfmOptions o;
  o.refine_focal = o.refine_distortion = true;
  const ViewGraph graph = BuildViewGraph(v.images, prior, v.names, o.view_graph);
  std::vector<SfmResult> single;
  for (double f : {1.0, 2.0}) {
    std::vector<Camera> start = prior;
    for (Camera& c : start) c.fx *= f, c.fy *= f;
    ViewGraph measured = graph;
    MeasureEdgesWithIntrinsics(start, &measured);
    single.push_back(RunGlobalSfm(measured, start, o));
  }
  SfmOptions starts = o;
  starts.focal_starts = {1.0, 2.0};
  const SfmResult r = RunGlobalSfm(graph, prior, starts);
  const int best = single[1].num_observations > single[0].num_observations ? 1 : 0;
  std::printf("focal starts: x1 %.2f px %d observations, x2 %.2f px %d; kept %.2f px (truth %.2f)\n",
              single[0].cameras[0].fx, single[0].num_observations, single[1].cameras[0].fx, single[1].num_observations,
              r.cameras[0].fx, truth);
  int counted = 0;
  for (const SfmPoint& p : r.points) counted += static_cast<int>(p.elements.size());
  EXPECT_EQ(r.num_observations, counted);
  EXPECT_EQ(r.num_observations, single[best].num_observations);
  EXPECT_EQ(r.cameras[0].fx, single[best].cameras[0].fx);
  for (size_t k = 0; k < r.cam_from_world.size(); ++k)
    EXPECT_TRUE(r.cam_from_world[k].rotation.isApprox(single[best].cam_from_world[k].rotation, 1e-12)) << k;
  EXPECT_NEAR(r.cameras[0].fx, truth, 0.03 * truth);  // 3 %: the sanitized clang build renders other views
  starts.focal_starts = {1.0, 0.0};
  EXPECT_THROW(RunGlobalSfm(graph, prior, starts), std::invalid_argument);
}

// Two starts kept as many observations (within 2 %) but ended 40 px apart: the photos do not tell
// the two focal lengths apart, so the kept one's standard deviation is at least their spread (the
// covariance's 5 px said 0.7 %). A start that kept 5 % fewer (a wrong minimum) does not count, and
// a covariance wider than the spread stays; only where the starts disagree is a third solved.
TEST(GlobalSfm, FocalStartsEndingApartWithAsMuchSupportWidenTheFocalsStandardDeviation) {
  const auto result = [](double focal, int observations, double stddev) {
    SfmResult r;
    r.cameras.assign(2, Camera::Pinhole(640, 480, focal, focal, 320, 240));
    r.num_observations = observations;
    r.focal_stddev_px.assign(2, stddev);
    return r;
  };
  std::vector<SfmResult> results = {result(740, 5000, 5), result(780, 4950, 5), result(600, 4750, 5)};
  WidenFocalStddevBySpread(0, {1.0, 1.4, 0.7}, &results);
  for (double sd : results[0].focal_stddev_px) EXPECT_NEAR(sd, 40 / std::sqrt(2.0), 1e-9);
  results = {result(740, 5000, 5), result(600, 4750, 5)};
  WidenFocalStddevBySpread(0, {1.0, 0.7}, &results);
  for (double sd : results[0].focal_stddev_px) EXPECT_EQ(sd, 5);
  results = {result(740, 5000, 50), result(780, 4990, 5)};
  EXPECT_FALSE(FocalStartsDisagree(results));  // the covariance already says more: no third start
  WidenFocalStddevBySpread(0, {1.0, 1.4}, &results);
  for (double sd : results[0].focal_stddev_px) EXPECT_EQ(sd, 50);
  // Which starts agree, as RunGlobalSfm asks before solving the start below the prior.
  EXPECT_TRUE(FocalStartsDisagree({result(740, 5000, 5), result(780, 4950, 5)}));
  EXPECT_FALSE(FocalStartsDisagree({result(740, 5000, 5), result(745, 4950, 5)}));  // within the covariance
  EXPECT_FALSE(FocalStartsDisagree({result(740, 5000, 5), result(600, 4750, 5)}));  // a worse minimum
  EXPECT_FALSE(FocalStartsDisagree({result(740, 5000, 5)}));
}

// SfmOptions::hold_focal_prior_above (an EXIF focal): where the photos determine the focal,
// a prior 5 % off is refined away; where the camera only translates, which leaves the focal free,
// the prior is held and the solution says so.
TEST(GlobalSfm, AFocalPriorIsHeldOnlyWhereThePhotosLeaveTheFocalFree) {
  SfmOptions o;
  o.refine_focal = true;
  o.focal_starts = {1.0, 1.2};
  o.focal_start_below = 0;
  o.hold_focal_prior_above = 0.05;
  const auto prior_of = [](const SyntheticScene& s, double factor) {
    std::vector<Camera> prior = s.cameras;
    for (Camera& c : prior) c.fx *= factor, c.fy *= factor;
    return prior;
  };
  SyntheticSceneOptions so;
  so.num_cameras = 10;
  const SyntheticScene determined = MakeSyntheticScene(so);
  const SfmResult r = RunGlobalSfm(determined.graph, prior_of(determined, 1.05), o);
  std::printf("focal prior 5 %% off, cameras turned: %.2f px (truth %.2f), held %d, stddev %.2f\n", r.cameras[0].fx,
              determined.cameras[0].fx, r.focal_prior_held, r.focal_stddev_px.empty() ? -1.0 : r.focal_stddev_px[0]);
  EXPECT_FALSE(r.focal_prior_held);
  EXPECT_NEAR(r.cameras[0].fx, determined.cameras[0].fx, 0.01 * determined.cameras[0].fx);
  so.pure_translation = true;
  const SyntheticScene free = MakeSyntheticScene(so);
  const std::vector<Camera> prior = prior_of(free, 1.05);
  const SfmResult h = RunGlobalSfm(free.graph, prior, o);
  std::printf("focal prior 5 %% off, cameras translated: %.2f px (prior %.2f), held %d, stddev %.2f\n", h.cameras[0].fx,
              prior[0].fx, h.focal_prior_held, h.focal_stddev_px.empty() ? -1.0 : h.focal_stddev_px[0]);
  EXPECT_TRUE(h.focal_prior_held);
  for (const Camera& c : h.cameras) EXPECT_EQ(c.fx, prior[0].fx);
  for (bool p : h.posed) EXPECT_TRUE(p);
  ASSERT_EQ(h.focal_stddev_px.size(), h.cameras.size());
  EXPECT_GT(h.focal_stddev_px[0], 0.01 * prior[0].fx);  // reported as not determined
  o.hold_focal_prior_above = 0;
  EXPECT_FALSE(RunGlobalSfm(free.graph, prior, o).focal_prior_held);
}

TEST(GlobalSfm, FewerThanThreeImagesOrASizeUnlikeItsCameraAreInputErrorsNamingTheFile) {
  const Camera cam = Camera::Pinhole(32, 24, 30, 30, 16, 12);
  try {
    PoseImages({Image(32, 24, 3), Image(32, 24, 3)}, {cam, cam}, {"a.png", "b.png"}, SfmOptions{});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("a.png"), std::string::npos) << e.what();
  }
  // Images of several sizes are fine (one camera each); an image unlike its camera is not.
  try {
    PoseImages({Image(32, 24, 3), Image(32, 24, 3), Image(40, 24, 3)}, {cam, cam, cam}, {"a.png", "b.png", "odd.png"},
               SfmOptions{});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("odd.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace nerfreg
