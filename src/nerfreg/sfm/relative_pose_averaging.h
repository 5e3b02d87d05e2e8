#pragma once
// Global cameras from relative poses: a relative rotation and a translation direction per edge
// (from any source: essential matrices, a pose network, a mix) -> cam_from_world per image.
//
// The same robust pipeline as the classical SfM (global_sfm.h) minus the points: rotation
// averaging (spanning-tree init, Cauchy refinement; rotation_averaging.h), then translation
// averaging of the directions of the rotation-consistent edges (translation_averaging.h). An edge
// may be given in both directions (i -> j and j -> i): both are used, and their disagreement is
// what a robust loss weighs down. Translation lengths are not used (a relative pose network's
// lengths are only known up to its depth scale), so the result is known up to a similarity.
//
// The output frame is the classical one: the first posed image's camera at the identity, the mean
// distance of the other posed cameras to it 1.
#include <vector>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/sfm/rotation_averaging.h"
#include "nerfreg/sfm/translation_averaging.h"

namespace nerfreg {

// x_in_j = j_from_i * x_in_i. The translation's length is ignored; a zero translation (no
// direction) makes the edge count for the rotations only.
struct RelativePose {
  int i = 0;
  int j = 0;
  Rigid3d j_from_i;
  // Relative weight in the rotation averaging (sqrt-scaled, as inlier counts are there); > 0.
  double weight = 1.0;
};

struct RelativePoseAveragingOptions {
  RotationAveragingOptions rotation;
  TranslationAveragingOptions translation;
  void Check() const;  // throws std::invalid_argument
};

struct RelativePoseAveragingResult {
  std::vector<Rigid3d> cam_from_world;  // per image; identity where !posed
  std::vector<bool> posed;              // in the largest component of the rotation-consistent edges
  // Per input edge: the angle between its measured relative rotation and the one of the result
  // (degrees; 180 where an end is not posed), the same for the translation direction (180 where
  // unused: an end not posed, a zero translation or a rotation outlier), and whether it was kept by
  // both averagings.
  std::vector<double> edge_rotation_error_deg;
  std::vector<double> edge_direction_error_deg;
  std::vector<bool> edge_inlier;
};

// Throws std::invalid_argument on an edge naming an image outside [0, num_images), a self edge or a
// non-positive weight.
RelativePoseAveragingResult GlobalPosesFromRelativePoses(int num_images, const std::vector<RelativePose>& edges,
                                                         const RelativePoseAveragingOptions& options);

}  // namespace nerfreg
