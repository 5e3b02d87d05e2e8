#include "nerfreg/sfm/global_sfm.h"

#include <cmath>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

ViewGraphOptions SfmViewGraphDefaults() {
  ViewGraphOptions o;
  o.contrast_threshold = 0.005;
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
  translation.Check();
  tracks.Check();
  bundle_adjustment.Check();
  if (round_reprojection_error_px.empty() || !(min_triangulation_angle_deg >= 0)) {
    throw std::invalid_argument("SfmOptions: out of range");
  }
  for (double t : round_reprojection_error_px)
    if (!(t > 0)) throw std::invalid_argument("SfmOptions: round_reprojection_error_px must be positive");
}

SfmResult RunGlobalSfm(const ViewGraph& graph, const std::vector<Camera>& cameras, const SfmOptions& options) {
  options.Check();
  const int n = static_cast<int>(graph.names.size());
  if (static_cast<int>(cameras.size()) != n || static_cast<int>(graph.keypoints.size()) != n) {
    throw std::invalid_argument("RunGlobalSfm: one camera and one keypoint list per image");
  }
  const Timer timer;
  SfmResult result;
  result.view_graph = graph;
  result.cam_from_world.assign(n, Rigid3d());
  result.posed.assign(n, false);

  Timer stage;
  const RotationAveragingResult rotations = AverageRotations(graph, options.rotation);
  result.times.Record("rotation averaging", stage.Seconds());
  stage.Restart();
  std::vector<bool> usable = rotations.edge_inlier;
  for (bool u : usable) result.num_edges_used += u;
  const TranslationAveragingResult centers =
      AverageTranslations(graph, rotations.cam_from_world, usable, options.translation);
  result.times.Record("translation averaging", stage.Seconds());
  int root = -1;
  for (int k = 0; k < n; ++k) {
    result.posed[k] = centers.solved[k];
    if (!result.posed[k]) continue;
    if (root < 0) root = k;
    const Eigen::Quaterniond& r = rotations.cam_from_world[k];
    result.cam_from_world[k] = Rigid3d(r, -(r * centers.centers[k]));
  }
  for (int k = 0; k < n; ++k)
    if (!result.posed[k]) result.not_posed.push_back(graph.names[k]);
  if (root < 0) {
    result.seconds_sfm = timer.Seconds();
    return result;
  }

  stage.Restart();
  const std::vector<Track> tracks = BuildTracks(graph, usable, options.tracks);
  result.times.Record("tracks", stage.Seconds());
  double seconds_triangulation = 0, seconds_ba = 0;
  for (double threshold : options.round_reprojection_error_px) {
    stage.Restart();
    TriangulationOptions tri;
    tri.max_reprojection_error_px = threshold;
    tri.min_angle_deg = options.min_triangulation_angle_deg;
    result.points.clear();
    for (const Track& track : tracks) {
      SfmPoint point;
      if (TriangulateTrack(track, graph.keypoints, cameras, result.cam_from_world, result.posed, tri, &point)) {
        result.points.push_back(std::move(point));
      }
    }
    seconds_triangulation += stage.Seconds();
    stage.Restart();
    [[maybe_unused]] const auto ba = BundleAdjust(cameras, graph.keypoints, result.posed, root, &result.cam_from_world,
                                                  &result.points, options.bundle_adjustment);
    seconds_ba += stage.Seconds();
    LOG_DEBUG("sfm round {:.1f} px: {} points, rms {:.3f} -> {:.3f} px, {} iterations, {:.2f} s", threshold,
              result.points.size(), ba.initial_rms_px, ba.final_rms_px, ba.iterations, stage.Seconds());
  }
  result.times.Record("triangulation", seconds_triangulation);
  result.times.Record("bundle adjustment", seconds_ba);
  // Final observations: those within the last threshold of the adjusted points.
  const double last = options.round_reprojection_error_px.back();
  std::vector<SfmPoint> kept;
  double sum_error = 0;
  int num_observations = 0;
  for (auto& point : result.points) {
    std::vector<TrackElement> good;
    double sum = 0;
    for (const auto& e : point.elements) {
      const double error = ReprojectionErrorPx(cameras[e.image], result.cam_from_world[e.image], point.x_in_world,
                                               graph.keypoints[e.image][e.keypoint]);
      if (error <= last) good.push_back(e), sum += error;
    }
    if (good.size() < 2) continue;
    point.elements = std::move(good);
    sum_error += sum;
    num_observations += static_cast<int>(point.elements.size());
    kept.push_back(std::move(point));
  }
  result.points = std::move(kept);
  result.num_points = static_cast<int>(result.points.size());
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

SfmResult PoseImages(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, const SfmOptions& options) {
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
  const ViewGraph graph = BuildViewGraph(images, cameras, names, options.view_graph, &times);
  const double seconds_view_graph = timer.Seconds();
  SfmResult result = RunGlobalSfm(graph, cameras, options);
  result.seconds_view_graph = seconds_view_graph;
  times.Append(result.times);
  result.times = times;
  for (const auto& name : result.not_posed)
    LOG_WARN("{}: not posed (no consistent two-view geometry with the others)", name);
  return result;
}

}  // namespace nerfreg
