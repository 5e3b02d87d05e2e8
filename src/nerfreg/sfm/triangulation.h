#pragma once
// Triangulation of tracks from posed cameras: linear (DLT on normalised image coordinates, so the
// intrinsics and distortion are taken out first), then checked: in front of every camera, a
// reprojection error below a threshold in pixels and a large enough triangulation angle. A track
// with a bad observation loses its worst observation and is tried again while two remain.
#include <Eigen/Core>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/sfm/tracks.h"

namespace nerfreg {

struct TriangulationOptions {
  double max_reprojection_error_px = 2.0;  // per observation, pixels
  double min_angle_deg = 1.0;              // largest angle between two of the point's viewing rays
  void Check() const;                      // throws std::invalid_argument
};

// A triangulated track: the world point and the observations that agree with it.
struct SfmPoint {
  Eigen::Vector3d x_in_world = Eigen::Vector3d::Zero();
  std::vector<TrackElement> elements;  // a subset of the track's, at most one per image
};

// Linear triangulation of one point from >= 2 views: cam_from_world[k] and the normalised image
// coordinates (z = 1) of its projection in view k. Returns false when the system is degenerate.
bool TriangulateDlt(const std::vector<Rigid3d>& cam_from_world, const std::vector<Eigen::Vector3d>& x_normalized,
                    Eigen::Vector3d* x_in_world);

// Reprojection error of a world point in pixels, or +inf behind the camera.
double ReprojectionErrorPx(const Camera& camera, const Rigid3d& cam_from_world, const Eigen::Vector3d& x_in_world,
                           const Eigen::Vector2d& uv);

// Triangulates a track from the elements whose image is posed. keypoints: ViewGraph::keypoints.
// Returns false (expected failure) when fewer than two consistent observations remain or the
// angle is too small.
bool TriangulateTrack(const Track& track, const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                      const std::vector<Camera>& cameras, const std::vector<Rigid3d>& cam_from_world,
                      const std::vector<bool>& posed, const TriangulationOptions& options, SfmPoint* point);

}  // namespace nerfreg
