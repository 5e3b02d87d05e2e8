#pragma once
// Global positioning: camera centres and scene points solved together from the averaged
// orientations and the keypoints' viewing rays, from a random start (GLOMAP, Pan et al. ECCV 2024;
// COLMAP 4's global mapper).
//
// Each observation of point p in image i gives a unit ray v_ip in the world frame (the keypoint's
// normalised direction rotated by R_i^T). The residual is
//     v_ip - s_ip * (X_p - c_i),     s_ip >= 0 a free scale per observation,
// under a Huber loss (the BATA form). Unlike translation averaging of pairwise directions
// (translation_averaging.h), every point is tied to every camera that sees it, so a wrong pairwise
// direction (a near-pure rotation, a planar pair) has no say of its own, and the collapsed
// solution (all centres together) costs |v_ip| = 1 per observation instead of nothing. The scale
// per observation makes the residual bounded, so starting from random positions converges without
// an initial translation estimate.
//
// The gauge: one camera centre is held at the origin; the overall scale stays free (it trades
// against the s_ip) and is set by the caller's final frame.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/sfm/tracks.h"

namespace nerfreg {

struct GlobalPositioningOptions {
  double huber_scale = 0.1;  // Huber scale of the residual (unit-ray units; GLOMAP's 0.1)
  int max_iterations = 100;  // Ceres iterations
  // Tracks used per image at most (the longest first): the positions need far fewer points than
  // the bundle adjustment, and the problem's cost grows with the observations. Each observation's
  // scale is its own parameter, so Ceres's Schur complement eliminates the scales and factors
  // points and cameras together: on 96 forward-facing views (tracks of 16 views) 300 took 1.8 s,
  // 150 0.7 s, for the same poses after the bundle adjustment.
  int max_tracks_per_image = 150;
  int min_track_length = 3;  // shorter tracks constrain too little (2-view points add no loop)
  unsigned int seed = 1;     // of the random start
  int num_threads = 1;       // Ceres threads
  void Check() const;        // throws std::invalid_argument
};

struct GlobalPositioningResult {
  std::vector<Eigen::Vector3d> centers;  // per image, world frame; zero where !solved
  std::vector<bool> solved;              // the images with enough tracks, in one component
  std::vector<int> track_index;          // the tracks used (into the input `tracks`)
  std::vector<Eigen::Vector3d> points;   // one per used track, world frame
  int num_observations = 0;
  double final_cost = 0;
  bool converged = false;
};

// cam_from_world: one orientation per image (averaged); `oriented`: images with an orientation.
// keypoints: ViewGraph::keypoints (pixels); cameras: one per image.
GlobalPositioningResult PositionCamerasAndPoints(const std::vector<Track>& tracks,
                                                 const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                                 const std::vector<Camera>& cameras,
                                                 const std::vector<Eigen::Quaterniond>& cam_from_world,
                                                 const std::vector<bool>& oriented,
                                                 const GlobalPositioningOptions& options);

}  // namespace nerfreg
