#pragma once
// Bundle adjustment (Ceres): refines every posed camera's cam_from_world and every point by
// minimising the reprojection error in pixels under a Huber loss, and optionally the intrinsics
// (self-calibration: focal length and radial distortion k1, k2, shared by the images of one camera
// group, as COLMAP refines one camera per make / model / size).
//
// The residual is the full projection (pinhole + OpenCV radial-tangential distortion) minus the
// keypoint, in pixels. Fisheye cameras keep the first-order residual on undistorted normalised
// coordinates (fx * (x/z - x_n), ...) and are never refined. The gauge: one camera is held fixed,
// and for the scale one translation coordinate of the camera farthest from it; the caller sets the
// final frame.
#include <map>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/sfm/triangulation.h"

namespace nerfreg {

struct BundleAdjustmentOptions {
  double huber_scale_px = 1.0;  // reprojection errors beyond this count linearly
  // Ceres iterations (COLMAP's default): on low-texture captures the cost is flat along small
  // rotation-translation trades and 50 stopped short of the minimum.
  int max_iterations = 100;
  // Up to this many cameras the reduced camera system is solved densely (DENSE_SCHUR, as COLMAP
  // chooses), beyond by conjugate gradients on the implicit Schur complement (ITERATIVE_SCHUR,
  // Jacobi-preconditioned): forward-facing views make that system dense (every camera sees every
  // other's points), and factorising it sparsely took most of the adjustment's time, for the same
  // iterations and poses (docs/poses_and_views.md).
  int dense_schur_max_cameras = 50;
  // Ceres threads. More than one makes sums over residuals (the cost, which steers the trust
  // region; with DENSE_SCHUR also the Schur complement) and so the result depend on the
  // scheduling: the same images would give different cameras from run to run (the SfM cache's
  // test caught it under load).
  int num_threads = 1;
  // false holds every rotation at its value (GLOMAP's first adjustment after global positioning:
  // positions settle before orientations may trade against them).
  bool refine_rotations = true;
  // Self-calibration, per camera group: the focal length (fx and fy scaled together) and the
  // radial distortion k1, k2. The principal point stays (it is poorly constrained, COLMAP's default).
  bool refine_focal = false;
  bool refine_distortion = false;
  // With refine_focal: after the solve, each group's focal length's standard deviation from the
  // covariance of the solution (ceres::Covariance on the intrinsics, marginalising poses and
  // points, scaled by the residuals' variance). Motions close to a critical one (centres on a
  // line, optical axes through one point) leave the focal free; this is how that shows.
  bool estimate_focal_stddev = false;
  void Check() const;  // throws std::invalid_argument
};

struct BundleAdjustmentSummary {
  double initial_rms_px = 0;  // over all observations, before
  double final_rms_px = 0;    // after
  int num_observations = 0;
  bool converged = false;
  int iterations = 0;  // Ceres iterations run
  // Per camera group refined (estimate_focal_stddev): the focal's standard deviation in pixels;
  // infinity where the covariance is rank deficient (the data do not determine it at all).
  std::map<int, double> focal_stddev_px;
};

// fixed_camera: the posed image whose pose is held constant. Cameras with !posed[k] and points'
// elements in them are left alone. camera_group: per image, the index of its shared intrinsics
// (empty: every image its own); only read when refining intrinsics, which then writes the refined
// values back into every camera of the group.
BundleAdjustmentSummary BundleAdjust(std::vector<Camera>* cameras, const std::vector<int>& camera_group,
                                     const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                     const std::vector<bool>& posed, int fixed_camera,
                                     std::vector<Rigid3d>* cam_from_world, std::vector<SfmPoint>* points,
                                     const BundleAdjustmentOptions& options);

// The indices of a subset of `points` spread over every posed image: each image is cut into
// cells_per_side x cells_per_side cells and points are taken longest track first while one of
// their observations falls in a cell holding fewer than per_cell taken points. Self-calibration
// refines the intrinsics on such a subset first (the focal length's slow valley costs many
// iterations, each over every observation), so the adjustment over all points starts close.
std::vector<int> SpreadPointSubset(const std::vector<SfmPoint>& points,
                                   const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                   const std::vector<Camera>& cameras, const std::vector<bool>& posed,
                                   int cells_per_side, int per_cell);

// The same with fixed intrinsics.
BundleAdjustmentSummary BundleAdjust(const std::vector<Camera>& cameras,
                                     const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                     const std::vector<bool>& posed, int fixed_camera,
                                     std::vector<Rigid3d>* cam_from_world, std::vector<SfmPoint>* points,
                                     const BundleAdjustmentOptions& options);

}  // namespace nerfreg
