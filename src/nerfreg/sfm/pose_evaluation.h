#pragma once
// Accuracy of estimated cameras against ground truth, up to the similarity that poses from images
// cannot know: align, then per camera the rotation error (geodesic, degrees) and the camera-centre
// error (scene units of the ground truth, and as a fraction of the widest ground-truth baseline).
#include <string>
#include <vector>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

enum class PoseAlignment {
  // Sim(3) Umeyama on camera centres (geometry/alignment.h), as DBARF / BARF evaluate. Needs 3
  // non-collinear centres.
  kCenters,
  // The rotation from the chordal mean of the per-camera rotation offsets, then scale and
  // translation by least squares on the centres: defined for any >= 2 cameras, collinear or not.
  kRotationsAndCenters,
};

struct PoseEvaluation {
  bool aligned = false;  // false: too few (or degenerate) cameras to align
  Sim3d gt_from_estimate;
  std::vector<double> rotation_error_deg;  // per evaluated camera, in the order given
  std::vector<double> center_error;        // ground-truth units
  double widest_baseline = 0;              // largest distance between two ground-truth centres
  double mean_rotation_deg = 0, median_rotation_deg = 0;
  double mean_center = 0, median_center = 0;  // ground-truth units
  // Median centre error as a percentage of the widest ground-truth baseline.
  double median_center_percent = 0;
};

// estimated and ground_truth: cam_from_world of the same cameras in the same order (>= 2).
PoseEvaluation EvaluatePoses(const std::vector<Rigid3d>& estimated, const std::vector<Rigid3d>& ground_truth,
                             PoseAlignment alignment);

}  // namespace nerfreg
