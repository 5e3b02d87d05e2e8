#include "nerfreg/sfm/global_sfm.h"

#include <algorithm>
#include <numeric>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <map>
#include <stdexcept>
#include <thread>

#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/stats.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/viewgraph/two_view_refinement.h"

namespace nerfreg {

ViewGraphOptions SfmViewGraphDefaults() {
  ViewGraphOptions o;
  o.contrast_threshold = 0.01;
  o.sparse_contrast_threshold = 0.005;
  o.min_inliers = 15;
  o.upsample = 2;
  // Enlarging helps the small renders (128x96, 320x240) and costs photos most of the time: at
  // 640x480 it made matching ~6x slower for the same rotations (docs/notes/2026-11-25-sift-upsample.md).
  o.upsample_max_side = 1000;
  return o;
}

void SfmOptions::Check() const {
  view_graph.Check();
  rotation.Check();
  global_positioning.Check();
  translation.Check();
  tracks.Check();
  keypoint_refinement.Check();
  bundle_adjustment.Check();
  if (round_reprojection_error_px.empty() || !(min_triangulation_angle_deg >= 0) || !(collapse_fraction >= 0) ||
      !(reverify_matches_px >= 0) ||
      !(max_edge_direction_residual_deg >= 0 && max_edge_direction_residual_deg <= 180) || collapse_retries < 0 ||
      !(focal_start_below >= 0 && std::isfinite(focal_start_below)) ||
      !(hold_focal_prior_above >= 0 && std::isfinite(hold_focal_prior_above)) || subset_cells < 0 ||
      subset_per_cell < 1) {
    throw std::invalid_argument("SfmOptions: out of range");
  }
  for (double t : round_reprojection_error_px)
    if (!(t > 0)) throw std::invalid_argument("SfmOptions: round_reprojection_error_px must be positive");
  for (double f : focal_starts)
    if (!(f > 0 && std::isfinite(f))) throw std::invalid_argument("SfmOptions: focal_starts must be positive");
}

namespace {

// The posed images' camera centres (zero where not posed), their mean and how many there are.
struct PosedCentres {
  std::vector<Eigen::Vector3d> centres;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  int count = 0;
};

PosedCentres CollectPosedCentres(const std::vector<Rigid3d>& cam_from_world, const std::vector<bool>& posed) {
  PosedCentres p;
  p.centres.assign(cam_from_world.size(), Eigen::Vector3d::Zero());
  for (size_t k = 0; k < cam_from_world.size(); ++k) {
    if (!posed[k]) continue;
    p.centres[k] = cam_from_world[k].Inverse().translation;
    p.mean += p.centres[k];
    ++p.count;
  }
  if (p.count > 0) p.mean /= p.count;
  return p;
}

}  // namespace

std::vector<int> CoincidentCentres(const std::vector<Rigid3d>& cam_from_world, const std::vector<bool>& posed,
                                   double fraction) {
  const size_t n = cam_from_world.size();
  std::vector<int> out(n, -1);
  const auto [centres, mean, count] = CollectPosedCentres(cam_from_world, posed);
  if (count < 2) return out;
  double spread = 0;
  for (size_t k = 0; k < n; ++k)
    if (posed[k]) spread += (centres[k] - mean).squaredNorm();
  spread = std::sqrt(spread / count);
  for (size_t a = 0; a < n; ++a) {
    for (size_t b = 0; b < n && posed[a] && out[a] < 0; ++b) {
      if (b != a && posed[b] && (centres[a] - centres[b]).norm() <= fraction * spread) out[a] = static_cast<int>(b);
    }
  }
  return out;
}

EdgeDirectionCheck CheckEdgeDirections(const std::vector<Rigid3d>& cam_from_world, const std::vector<bool>& posed,
                                       const ViewGraph& graph, const std::vector<bool>& edge_used,
                                       double max_median_residual_deg) {
  EdgeDirectionCheck out;
  const size_t n = cam_from_world.size();
  const auto [centres, mean, count] = CollectPosedCentres(cam_from_world, posed);
  out.off_line_fraction = std::numeric_limits<double>::infinity();
  if (count >= 3) {
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (size_t k = 0; k < n; ++k)
      if (posed[k]) scatter += (centres[k] - mean) * (centres[k] - mean).transpose();
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();  // ascending
    if (ev(2) > 0) out.off_line_fraction = std::sqrt(std::max(0.0, ev(0) + ev(1)) / ev(2));
  }
  std::vector<double> residuals;
  for (size_t e = 0; e < graph.edges.size(); ++e) {
    const ViewGraphEdge& edge = graph.edges[e];
    if ((!edge_used.empty() && !edge_used[e]) || edge.panoramic || !posed[edge.i] || !posed[edge.j]) continue;
    // The direction from centre i to centre j in camera i's frame, then in the world's.
    const Eigen::Vector3d in_i = -(edge.j_from_i.rotation.conjugate() * edge.j_from_i.translation);
    const Eigen::Vector3d solved = centres[edge.j] - centres[edge.i];
    if (!(in_i.norm() > 0) || !(solved.norm() > 0)) continue;
    const Eigen::Vector3d in_world = cam_from_world[edge.i].rotation.conjugate() * in_i.normalized();
    residuals.push_back(std::acos(std::clamp(in_world.dot(solved.normalized()), -1.0, 1.0)) * 180 / M_PI);
  }
  out.num_edges = static_cast<int>(residuals.size());
  if (residuals.empty()) return out;
  out.median_residual_deg = UpperMedian(residuals);
  out.contradicted = out.num_edges >= 3 && out.median_residual_deg > max_median_residual_deg;
  return out;
}

namespace {

// One group for equal cameras, else one per image.
std::vector<int> DefaultCameraGroups(const std::vector<Camera>& cameras) {
  std::vector<int> same(cameras.size(), 0), own(cameras.size());
  std::iota(own.begin(), own.end(), 0);
  for (const Camera& camera : cameras)
    if (camera != cameras[0]) return own;
  return same;
}

// The median angle (degrees) between the two rays of an edge's inlier matches once both are
// rotated into the world frame: ~0 for photos taken from one spot (a pure rotation), larger the
// more the two views' centres differ relative to the scene's depth.
double MedianParallaxDeg(const ViewGraphEdge& edge, const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                         const std::vector<Camera>& cameras, const std::vector<Rigid3d>& cam_from_world) {
  std::vector<double> angles;
  for (const auto& [a, b] : edge.inlier_matches) {
    const Eigen::Vector3d ra =
        cam_from_world[edge.i].rotation.inverse() * cameras[edge.i].CamFromImg(keypoints[edge.i][a]);
    const Eigen::Vector3d rb =
        cam_from_world[edge.j].rotation.inverse() * cameras[edge.j].CamFromImg(keypoints[edge.j][b]);
    angles.push_back(std::atan2(ra.cross(rb).norm(), ra.dot(rb)) * 180 / M_PI);
  }
  if (angles.empty()) return 0;
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  return angles[angles.size() / 2];
}

// Parallax above which two images cannot share a camera centre.
constexpr double kCollapseParallaxDeg = 1.0;

// The edge's inlier matches whose Sampson distance to the epipolar geometry of the two posed
// cameras is below max_px (pixels, at image j's focal length); none when the two centres coincide.
std::vector<std::pair<int, int>> MatchesAgreeingWithPoses(const ViewGraphEdge& edge,
                                                          const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                                          const std::vector<Camera>& cameras,
                                                          const std::vector<Rigid3d>& cam_from_world, double max_px) {
  std::vector<std::pair<int, int>> kept;
  const Rigid3d j_from_i = cam_from_world[edge.j] * cam_from_world[edge.i].Inverse();
  if (j_from_i.translation.norm() < 1e-12) return kept;  // no epipolar geometry
  const Eigen::Matrix3d essential = Skew(j_from_i.translation.normalized()) * j_from_i.rotation.toRotationMatrix();
  const double max_normalized = max_px / cameras[edge.j].fx;
  for (const auto& [a, b] : edge.inlier_matches) {
    const Eigen::Vector2d xa = cameras[edge.i].CamFromImg(keypoints[edge.i][a]).hnormalized();
    const Eigen::Vector2d xb = cameras[edge.j].CamFromImg(keypoints[edge.j][b]).hnormalized();
    if (std::abs(SampsonDistance(essential, xa, xb)) < max_normalized) kept.push_back({a, b});
  }
  return kept;
}

// The graph's edges with their inlier matches checked again against solved poses
// (MatchesAgreeingWithPoses). Every edge between posed images is checked, also those that
// rotation averaging left out: on low-texture captures most two-view estimates are wrong (castle:
// 430 of 745 edges left out) while many of their matches are right, and tracks from them are longer.
ViewGraph PoseVerifiedGraph(const ViewGraph& graph, const std::vector<Camera>& cameras,
                            const std::vector<Rigid3d>& cam_from_world, const std::vector<bool>& posed, double max_px) {
  ViewGraph verified;
  verified.names = graph.names;
  verified.cameras = graph.cameras;
  verified.keypoints = graph.keypoints;
  for (const ViewGraphEdge& edge : graph.edges) {
    if (!posed[edge.i] || !posed[edge.j]) continue;
    ViewGraphEdge kept = edge;
    kept.inlier_matches = MatchesAgreeingWithPoses(edge, graph.keypoints, cameras, cam_from_world, max_px);
    if (!kept.inlier_matches.empty()) verified.edges.push_back(std::move(kept));
  }
  return verified;
}

// Centres whose rms distance from their line is below this fraction of their spread along it are
// said to lie on it (in the report of a contradicted solution).
constexpr double kOnLineFraction = 0.05;

struct Solution {
  std::vector<Rigid3d> cam_from_world;
  std::vector<bool> posed;
  std::vector<SfmPoint> points;
  std::vector<Camera> cameras;
  std::vector<int> collapsed_with;        // per image: the image whose centre it wrongly shares, or -1
  std::map<int, double> focal_stddev_px;  // per camera group, from the last adjustment
};

}  // namespace

void MeasureEdgesWithIntrinsics(const std::vector<Camera>& cameras, ViewGraph* graph) {
  if (cameras.size() != graph->cameras.size() || cameras.size() != graph->keypoints.size())
    throw std::invalid_argument("MeasureEdgesWithIntrinsics: cameras, graph cameras and keypoints differ in count");
  for (ViewGraphEdge& e : graph->edges) {
    if (e.panoramic || (cameras[e.i] == graph->cameras[e.i] && cameras[e.j] == graph->cameras[e.j])) continue;
    std::vector<Eigen::Vector2d> xi, xj;
    for (const auto& [a, b] : e.inlier_matches) {
      xi.push_back(cameras[e.i].CamFromImg(graph->keypoints[e.i][a]).head<2>());
      xj.push_back(cameras[e.j].CamFromImg(graph->keypoints[e.j][b]).head<2>());
    }
    Eigen::Matrix3d rot = e.j_from_i.RotationMatrix();
    Eigen::Vector3d trans = e.j_from_i.translation;
    RefineRelativePose(xi, xj, 1.0 / cameras[e.i].fx, &rot, &trans);  // 1 px, the view graph's threshold
    e.j_from_i = Rigid3d(Eigen::Quaterniond(rot), trans.normalized());
  }
  graph->cameras = cameras;
}

namespace {

// RunGlobalSfm from one start: the cameras as given.
SfmResult SolveFromCameras(const ViewGraph& graph, const std::vector<Camera>& cameras, const SfmOptions& options,
                           const std::vector<int>& camera_group) {
  const int n = static_cast<int>(graph.names.size());
  if (static_cast<int>(cameras.size()) != n || static_cast<int>(graph.keypoints.size()) != n ||
      (!camera_group.empty() && static_cast<int>(camera_group.size()) != n)) {
    throw std::invalid_argument("RunGlobalSfm: one camera, keypoint list and group per image");
  }
  const std::vector<int> groups = camera_group.empty() ? DefaultCameraGroups(cameras) : camera_group;
  const Timer timer;
  SfmResult result;
  result.view_graph = graph;
  result.cameras = cameras;
  result.cam_from_world.assign(n, Rigid3d());
  result.posed.assign(n, false);
  result.not_posed_reason.assign(n, "");

  Timer stage;
  const RotationAveragingResult rotations = AverageRotations(graph, options.rotation);
  result.times.Record("rotation averaging", stage.Seconds());
  std::vector<bool> usable = rotations.edge_inlier;
  for (bool u : usable) result.num_edges_used += u;
  result.edge_used = usable;
  stage.Restart();
  const std::vector<Track> first_tracks = BuildTracks(graph, usable, options.tracks);
  result.times.Record("tracks", stage.Seconds());

  // Positions, then rounds of triangulation and bundle adjustment; again from another random start
  // while the solution has collapsed.
  double seconds_positioning = 0, seconds_triangulation = 0, seconds_ba = 0;
  Solution solution;
  for (int attempt = 0; attempt <= options.collapse_retries; ++attempt) {
    Solution s;
    s.cameras = cameras;
    s.cam_from_world.assign(n, Rigid3d());
    s.posed.assign(n, false);
    s.collapsed_with.assign(n, -1);
    stage.Restart();
    std::vector<Eigen::Vector3d> centers(n, Eigen::Vector3d::Zero());
    // A collapsed solution is solved again by global positioning, from another random start.
    const SfmPositioning positioning = attempt == 0 ? options.positioning : SfmPositioning::kGlobalPositioning;
    if (positioning == SfmPositioning::kGlobalPositioning) {
      GlobalPositioningOptions gp = options.global_positioning;
      gp.seed += attempt;
      const GlobalPositioningResult positions = PositionCamerasAndPoints(
          first_tracks, graph.keypoints, cameras, rotations.cam_from_world, rotations.connected, gp);
      centers = positions.centers;
      s.posed = positions.solved;
    } else {
      const TranslationAveragingResult averaged =
          AverageTranslations(graph, rotations.cam_from_world, usable, options.translation);
      centers = averaged.centers;
      s.posed = averaged.solved;
    }
    seconds_positioning += stage.Seconds();
    int root = -1;
    for (int k = 0; k < n; ++k) {
      if (!s.posed[k]) continue;
      if (root < 0) root = k;
      const Eigen::Quaterniond& r = rotations.cam_from_world[k];
      s.cam_from_world[k] = Rigid3d(r, -(r * centers[k]));
    }
    if (root < 0) {
      solution = std::move(s);
      break;
    }
    std::vector<Track> tracks = first_tracks;
    for (size_t round = 0; round < options.round_reprojection_error_px.size(); ++round) {
      const double threshold = options.round_reprojection_error_px[round];
      if (round == 1 && options.reverify_matches_px > 0) {
        tracks =
            BuildTracks(PoseVerifiedGraph(graph, s.cameras, s.cam_from_world, s.posed, options.reverify_matches_px), {},
                        options.tracks);
      }
      stage.Restart();
      TriangulationOptions tri;
      tri.max_reprojection_error_px = threshold;
      tri.min_angle_deg = options.min_triangulation_angle_deg;
      // Every track at the current cameras (again after the intrinsics' subset adjustment below).
      auto triangulate_all = [&] {
        s.points.clear();
        for (const Track& track : tracks) {
          SfmPoint point;
          if (TriangulateTrack(track, graph.keypoints, s.cameras, s.cam_from_world, s.posed, tri, &point))
            s.points.push_back(std::move(point));
        }
      };
      triangulate_all();
      seconds_triangulation += stage.Seconds();
      stage.Restart();
      const bool last_round = round + 1 == options.round_reprojection_error_px.size();
      if (!last_round && options.subset_cells > 0) {
        // Before the last round the poses and intrinsics only serve to verify the matches and
        // triangulate again: a spread subset of the points will do.
        std::vector<SfmPoint> subset;
        for (int k : SpreadPointSubset(s.points, graph.keypoints, s.cameras, s.posed, options.subset_cells,
                                       options.subset_per_cell))
          subset.push_back(std::move(s.points[k]));
        s.points = std::move(subset);
      }
      BundleAdjustmentOptions ba = options.bundle_adjustment;
      if (round == 0 && positioning == SfmPositioning::kGlobalPositioning) {
        // Positions first, orientations held (GLOMAP): the averaged rotations are better than the
        // positions at this point, and a free rotation would trade against a wrong position.
        ba.refine_rotations = false;
        BundleAdjust(&s.cameras, groups, graph.keypoints, s.posed, root, &s.cam_from_world, &s.points, ba);
        ba.refine_rotations = true;
      }
      ba.refine_focal = options.refine_focal && round > 0;
      ba.refine_distortion = options.refine_distortion && round > 0;
      double seconds_retriangulation = 0;
      if (last_round && (ba.refine_focal || ba.refine_distortion) && options.subset_cells > 0) {
        // The intrinsics on a spread subset, then every track again with them. (Earlier rounds
        // already adjust such a subset alone, above.)
        const std::vector<int> chosen = SpreadPointSubset(s.points, graph.keypoints, s.cameras, s.posed,
                                                          options.subset_cells, options.subset_per_cell);
        if (chosen.size() < s.points.size()) {
          std::vector<SfmPoint> subset;
          for (int k : chosen) subset.push_back(s.points[k]);
          const auto sub =
              BundleAdjust(&s.cameras, groups, graph.keypoints, s.posed, root, &s.cam_from_world, &subset, ba);
          LOG_DEBUG("sfm intrinsics on {} of {} points: rms {:.3f} -> {:.3f} px, {} iterations", subset.size(),
                    s.points.size(), sub.initial_rms_px, sub.final_rms_px, sub.iterations);
          const Timer retriangulation;
          triangulate_all();
          seconds_retriangulation = retriangulation.Seconds();
        }
      }
      ba.estimate_focal_stddev = last_round && ba.refine_focal;
      const auto summary =
          BundleAdjust(&s.cameras, groups, graph.keypoints, s.posed, root, &s.cam_from_world, &s.points, ba);
      s.focal_stddev_px = summary.focal_stddev_px;
      seconds_ba += stage.Seconds() - seconds_retriangulation;
      seconds_triangulation += seconds_retriangulation;
      LOG_DEBUG("sfm round {:.1f} px: {} points, rms {:.3f} -> {:.3f} px, {} iterations, {:.2f} s", threshold,
                s.points.size(), summary.initial_rms_px, summary.final_rms_px, summary.iterations, stage.Seconds());
    }
    // Coincident centres are a collapse only where the two images' own matches show parallax.
    int num_collapsed = 0;
    if (options.collapse_fraction > 0) {
      const std::vector<int> coincident = CoincidentCentres(s.cam_from_world, s.posed, options.collapse_fraction);
      const std::vector<bool> collapsed = CollapsedCentres(graph, s.cameras, s.cam_from_world, coincident);
      for (int k = 0; k < n; ++k) {
        if (!collapsed[k]) continue;
        s.collapsed_with[k] = coincident[k];
        ++num_collapsed;
      }
    }
    solution = std::move(s);
    if (num_collapsed == 0 || attempt == options.collapse_retries) break;
    ++result.num_collapse_resolves;
    LOG_INFO("sfm: {} camera centres collapsed onto others; solving again from another start ({}/{})", num_collapsed,
             attempt + 1, options.collapse_retries);
  }
  // Centres contradicting the two-view directions are reported, not solved again: global
  // positioning from other random starts and translation averaging reached the same contradicted
  // solutions on the low-texture renders where this was seen.
  // Self-calibrated, the edges were measured with the prior intrinsics: again with the refined ones,
  // so that whatever compares the cameras with the edges (the check below, each pose's confidence,
  // auto's checks of network poses) compares like with like.
  // (A graph without cameras, as synthetic tests build them, says nothing to compare with.)
  if (solution.cameras.size() == static_cast<size_t>(n) && result.view_graph.cameras.size() == static_cast<size_t>(n))
    MeasureEdgesWithIntrinsics(solution.cameras, &result.view_graph);
  if (options.max_edge_direction_residual_deg > 0 && solution.posed.size() == static_cast<size_t>(n)) {
    const EdgeDirectionCheck directions = CheckEdgeDirections(
        solution.cam_from_world, solution.posed, result.view_graph, usable, options.max_edge_direction_residual_deg);
    LOG_DEBUG("sfm centres against the two-view directions: median {:.1f} deg over {} edges",
              directions.median_residual_deg, directions.num_edges);
    if (directions.contradicted) {
      char buf[300];
      std::snprintf(buf, sizeof(buf),
                    "the camera centres contradict the two-view directions of the edges they were solved from "
                    "(median %.0f deg over %d edges%s): a collapsed solution",
                    directions.median_residual_deg, directions.num_edges,
                    directions.off_line_fraction < kOnLineFraction ? ", the centres on a line" : "");
      result.degenerate = buf;
      LOG_WARN("sfm: {}", result.degenerate);
    }
  }
  result.times.Record("positioning", seconds_positioning);
  result.times.Record("triangulation", seconds_triangulation);
  result.times.Record("bundle adjustment", seconds_ba);
  result.cam_from_world = solution.cam_from_world;
  result.posed = solution.posed;
  result.points = std::move(solution.points);
  result.cameras = solution.cameras;
  if (!solution.focal_stddev_px.empty()) {
    result.focal_stddev_px.assign(n, 0.0);
    for (int k = 0; k < n; ++k) {
      const auto it = solution.focal_stddev_px.find(groups[k]);
      if (it != solution.focal_stddev_px.end()) result.focal_stddev_px[k] = it->second;
    }
  }
  // Images still collapsed are not posed: of each coincident pair, the one seen in fewer points.
  if (!solution.collapsed_with.empty()) {
    std::vector<int> seen(n, 0);
    for (const auto& point : result.points)
      for (const auto& e : point.elements) ++seen[e.image];
    for (int k = 0; k < n; ++k) {
      const int other = solution.collapsed_with[k];
      if (other < 0 || !result.posed[k] || !result.posed[other]) continue;
      const int drop = seen[k] <= seen[other] ? k : other;
      result.posed[drop] = false;
      result.not_posed_reason[drop] = "its camera centre coincides with " + graph.names[drop == k ? other : k] +
                                      "'s although their matches show parallax (a collapsed solution)";
    }
  }
  int root = -1;
  for (int k = 0; k < n; ++k) {
    if (result.posed[k] && root < 0) root = k;
    if (result.posed[k] || !result.not_posed_reason[k].empty()) continue;
    result.not_posed_reason[k] = rotations.connected[k] ? "too few tracks shared with the posed images"
                                                        : "no consistent two-view geometry with the others";
  }
  for (int k = 0; k < n; ++k)
    if (!result.posed[k]) result.not_posed.push_back(graph.names[k]), result.cam_from_world[k] = Rigid3d();
  if (root < 0) {
    result.points.clear();
    result.seconds_sfm = timer.Seconds();
    return result;
  }
  const std::vector<Camera>& final_cameras = result.cameras;
  // Final observations: those within the last threshold of the adjusted points.
  const double last = options.round_reprojection_error_px.back();
  std::vector<SfmPoint> kept;
  double sum_error = 0;
  int num_observations = 0;
  for (auto& point : result.points) {
    std::vector<TrackElement> good;
    double sum = 0;
    for (const auto& e : point.elements) {
      const double error = ReprojectionErrorPx(final_cameras[e.image], result.cam_from_world[e.image], point.x_in_world,
                                               graph.keypoints[e.image][e.keypoint]);
      if (error <= last && result.posed[e.image]) good.push_back(e), sum += error;
    }
    if (good.size() < 2) continue;
    point.elements = std::move(good);
    sum_error += sum;
    num_observations += static_cast<int>(point.elements.size());
    kept.push_back(std::move(point));
  }
  result.points = std::move(kept);
  result.num_points = static_cast<int>(result.points.size());
  result.num_observations = num_observations;
  result.mean_reprojection_error_px = num_observations > 0 ? sum_error / num_observations : 0;

  // The frame: the root camera at the identity, mean distance of the others to it = 1.
  const Rigid3d world_from_root = result.cam_from_world[root].Inverse();
  double mean_distance = 0;
  int count = 0;
  for (int k = 0; k < n; ++k)
    if (result.posed[k] && k != root) {
      mean_distance += (result.cam_from_world[k].Inverse().translation - world_from_root.translation).norm();
      ++count;
    }
  mean_distance = count > 0 && mean_distance > 0 ? mean_distance / count : 1.0;
  const Sim3d new_from_old = Sim3d(1.0 / mean_distance, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) *
                             Sim3d(result.cam_from_world[root]);
  for (int k = 0; k < n; ++k)
    if (result.posed[k]) result.cam_from_world[k] = new_from_old.TransformCamera(result.cam_from_world[k]);
  for (auto& point : result.points) point.x_in_world = new_from_old * point.x_in_world;
  result.seconds_sfm = timer.Seconds();
  return result;
}

// The sample standard deviation of image k's focal length over the results whose observations are
// comparable to results[kept]'s (kFocalSpreadComparableObservations); 0 where fewer than two are.
double ComparableFocalSpread(const std::vector<SfmResult>& results, int kept, size_t k) {
  const SfmResult& best = results[kept];
  std::vector<double> focal;
  for (const SfmResult& r : results) {
    if (r.cameras.size() == best.cameras.size() && k < r.cameras.size() &&
        r.num_observations >= kFocalSpreadComparableObservations * best.num_observations)
      focal.push_back(r.cameras[k].fx);
  }
  if (focal.size() < 2) return 0;
  double mean = 0, squares = 0;
  for (double f : focal) mean += f / focal.size();
  for (double f : focal) squares += (f - mean) * (f - mean);
  return std::sqrt(squares / (focal.size() - 1));
}

int MostObservations(const std::vector<SfmResult>& results) {
  int best = 0;
  for (int s = 0; s < static_cast<int>(results.size()); ++s)
    if (results[s].num_observations > results[best].num_observations) best = s;
  return best;
}

// Whether the photos leave the focal free (SfmOptions::hold_focal_prior_above): the starts end apart
// with as much support (`disagree`: the start decides), or the kept start's standard deviation is
// above `bound` of its focal for some camera (pure translation). Where the starts agree their spread
// is below the standard deviation, so widening it by the spread would change nothing here.
bool FocalLeftFree(const std::vector<SfmResult>& results, bool disagree, double bound) {
  const SfmResult& kept = results[MostObservations(results)];
  bool free_focal = disagree;
  for (size_t k = 0; k < kept.focal_stddev_px.size(); ++k)
    free_focal |= !(kept.focal_stddev_px[k] <= bound * kept.cameras[k].fx);
  return free_focal;
}

}  // namespace

std::vector<bool> CollapsedCentres(const ViewGraph& graph, const std::vector<Camera>& cameras,
                                   const std::vector<Rigid3d>& cam_from_world, const std::vector<int>& coincident) {
  std::vector<bool> collapsed(coincident.size(), false);
  for (size_t k = 0; k < coincident.size(); ++k) {
    if (coincident[k] < 0) continue;
    const ViewGraphEdge* edge = graph.FindEdge(static_cast<int>(k), coincident[k]);
    collapsed[k] =
        edge != nullptr && MedianParallaxDeg(*edge, graph.keypoints, cameras, cam_from_world) > kCollapseParallaxDeg;
  }
  return collapsed;
}

bool FocalStartsDisagree(const std::vector<SfmResult>& results) {
  if (results.empty()) return false;
  const int best = MostObservations(results);
  const std::vector<double>& sd = results[best].focal_stddev_px;
  for (size_t k = 0; k < sd.size(); ++k)
    if (ComparableFocalSpread(results, best, k) > sd[k]) return true;
  return false;
}

void WidenFocalStddevBySpread(int kept, const std::vector<double>& starts, std::vector<SfmResult>* results) {
  SfmResult& best = (*results)[kept];
  if (best.focal_stddev_px.size() != best.cameras.size()) return;
  double widest = 0;
  for (size_t k = 0; k < best.cameras.size(); ++k) {
    const double spread = ComparableFocalSpread(*results, kept, k);
    if (spread > best.focal_stddev_px[k]) best.focal_stddev_px[k] = spread, widest = std::max(widest, spread);
  }
  if (widest > 0) {
    LOG_INFO(
        "sfm: starts keeping as many observations (within {:.0f} %) end at focal lengths that differ by a "
        "standard deviation of {:.1f} px ({} starts): the focal's standard deviation is at least that",
        100 * (1 - kFocalSpreadComparableObservations), widest, starts.size());
  }
}

SfmResult RunGlobalSfm(const ViewGraph& graph, const std::vector<Camera>& cameras, const SfmOptions& options,
                       const std::vector<int>& camera_group) {
  options.Check();
  if (!options.refine_focal || options.focal_starts.size() < 2)
    return SolveFromCameras(graph, cameras, options, camera_group);
  const Timer timer;
  std::vector<double> starts = options.focal_starts;
  std::vector<SfmResult> results(starts.size());
  std::vector<std::exception_ptr> errors(starts.size());
  // Each start is single-threaded (Ceres with one thread): two at a time on two threads.
  const auto solve = [&](size_t s) {
    try {
      std::vector<Camera> start = cameras;
      for (Camera& c : start) c.fx *= starts[s], c.fy *= starts[s];
      ViewGraph measured = graph;
      if (measured.cameras.size() == cameras.size()) MeasureEdgesWithIntrinsics(start, &measured);
      results[s] = SolveFromCameras(measured, start, options, camera_group);
    } catch (...) {
      errors[s] = std::current_exception();
    }
  };
  for (size_t s = 0; s < starts.size(); s += 2) {
    std::thread second;
    if (s + 1 < starts.size()) second = std::thread(solve, s + 1);
    solve(s);
    if (second.joinable()) second.join();
  }
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  const auto log_starts = [&] {
    for (size_t s = 0; s < starts.size(); ++s) {
      LOG_INFO("sfm: self-calibration from focal {:.1f} px (x{:.2f}): {:.1f} px, {} points, {} observations",
               cameras[0].fx * starts[s], starts[s], results[s].cameras.empty() ? 0.0 : results[s].cameras[0].fx,
               results[s].num_points, results[s].num_observations);
    }
  };
  const bool disagree = FocalStartsDisagree(results);
  if (options.hold_focal_prior_above > 0 && FocalLeftFree(results, disagree, options.hold_focal_prior_above)) {
    const int best = MostObservations(results);
    log_starts();
    WidenFocalStddevBySpread(best, starts, &results);
    SfmOptions held = options;
    held.refine_focal = false;
    held.focal_starts.clear();
    held.hold_focal_prior_above = 0;
    ViewGraph measured = graph;
    if (measured.cameras.size() == cameras.size()) MeasureEdgesWithIntrinsics(cameras, &measured);
    SfmResult result = SolveFromCameras(measured, cameras, held, camera_group);
    result.focal_stddev_px = results[best].focal_stddev_px;
    result.focal_prior_held = true;
    LOG_INFO(
        "sfm: the photos leave the focal free ({}; start x{:.2f}: {:.1f} +- {:.1f} px): solved with the prior focal "
        "held ({:.1f} px), {} points, {} observations; {} solves in {:.2f} s",
        disagree ? "the starts end apart with as much support" : "its standard deviation is beyond the bound",
        starts[best], results[best].cameras[0].fx,
        results[best].focal_stddev_px.empty() ? 0.0 : results[best].focal_stddev_px[0], cameras[0].fx,
        result.num_points, result.num_observations, starts.size() + 1, timer.Seconds());
    return result;
  }
  // Where the starts end apart with as much support the photos leave the focal free: one more start,
  // below the prior, samples the other side of the valley (and a wide-angle lens without EXIF).
  if (options.focal_start_below > 0 && disagree) {
    starts.push_back(options.focal_start_below);
    results.emplace_back();
    errors.emplace_back();
    solve(starts.size() - 1);
    if (errors.back()) std::rethrow_exception(errors.back());
  }
  const int best = MostObservations(results);
  log_starts();
  LOG_INFO("sfm: kept the start x{:.2f} (most observations); {} starts in {:.2f} s", starts[best], starts.size(),
           timer.Seconds());
  WidenFocalStddevBySpread(best, starts, &results);
  return std::move(results[best]);
}

namespace {

template <typename ImageT>
SfmResult PoseImageSet(const std::vector<ImageT>& images, const std::vector<Camera>& cameras,
                       const std::vector<std::string>& names, const SfmOptions& options,
                       const std::vector<int>& camera_group) {
  options.Check();
  if (images.size() != cameras.size() || images.size() != names.size()) {
    throw std::invalid_argument("PoseImages: images, cameras and names differ in count");
  }
  if (images.size() < 3) {
    ThrowInputError(names.empty() ? std::string("images") : names[0], "",
                    "at least 3 images to pose, got " + std::to_string(images.size()));
  }
  const Timer timer;
  StageTimes times;
  ViewGraph graph = BuildViewGraph(images, cameras, names, options.view_graph, &times, camera_group);
  const double seconds_view_graph = timer.Seconds();  // the refinement has a stage time of its own
  if (options.refine_keypoints) {
    const Timer refinement;
    [[maybe_unused]] const KeypointRefinementSummary r = RefineTrackKeypoints(
        images, graph, BuildTracks(graph, {}, options.tracks), options.keypoint_refinement, &graph.keypoints);
    times.Record("keypoint refinement", refinement.Seconds());
    LOG_DEBUG("sfm keypoint refinement: {} tracks, {} observations moved (median {:.2f} px), {} refused", r.num_tracks,
              r.num_moved, r.median_shift_px, r.num_refused);
  }
  SfmResult result = RunGlobalSfm(graph, graph.cameras, options, camera_group);
  result.seconds_view_graph = seconds_view_graph;
  times.Append(result.times);
  result.times = times;
  for (size_t k = 0; k < names.size(); ++k)
    if (!result.posed[k]) LOG_WARN("{}: not posed ({})", names[k], result.not_posed_reason[k]);
  return result;
}

}  // namespace

SfmResult PoseImages(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, const SfmOptions& options,
                     const std::vector<int>& camera_group) {
  return PoseImageSet(images, cameras, names, options, camera_group);
}

SfmResult PoseImages(const std::vector<PackedImage>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, const SfmOptions& options,
                     const std::vector<int>& camera_group) {
  return PoseImageSet(images, cameras, names, options, camera_group);
}

}  // namespace nerfreg
