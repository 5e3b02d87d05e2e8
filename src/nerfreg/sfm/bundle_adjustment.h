#pragma once
// Bundle adjustment (Ceres): refines every posed camera's cam_from_world and every point by
// minimising the reprojection error in pixels under a Huber loss; intrinsics are fixed as given.
// Observations are undistorted once into normalised coordinates, and the residual is
// (fx * (x/z - x_n), fy * (y/z - y_n)): exactly pixels for a pinhole camera, a first-order
// approximation of them with distortion. The gauge: one camera is held fixed, and for the scale
// one translation coordinate of the camera farthest from it; the caller sets the final frame.
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/sfm/triangulation.h"

namespace nerfreg {

struct BundleAdjustmentOptions {
  double huber_scale_px = 1.0;  // reprojection errors beyond this count linearly
  int max_iterations = 50;      // Ceres iterations
  int num_threads = 1;          // Ceres threads
  void Check() const;           // throws std::invalid_argument
};

struct BundleAdjustmentSummary {
  double initial_rms_px = 0;  // over all observations, before
  double final_rms_px = 0;    // after
  int num_observations = 0;
  bool converged = false;
  int iterations = 0;  // Ceres iterations run
};

// fixed_camera: the posed image whose pose is held constant. Cameras with !posed[k] and points'
// elements in them are left alone.
BundleAdjustmentSummary BundleAdjust(const std::vector<Camera>& cameras,
                                     const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                                     const std::vector<bool>& posed, int fixed_camera,
                                     std::vector<Rigid3d>* cam_from_world, std::vector<SfmPoint>* points,
                                     const BundleAdjustmentOptions& options);

}  // namespace nerfreg
