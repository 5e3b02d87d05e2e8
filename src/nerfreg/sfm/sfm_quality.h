#pragma once
// Whether a global SfM solution is constrained well enough to trust. Bundle adjustment can reach
// a sub-pixel reprojection error on a wrong solution when the data cannot tell solutions apart:
// on 12 images of 32x24 pixels it reports a fraction of a pixel with the cameras degrees off. Such
// solutions have few, short tracks seen under small angles, and pixels too coarse for the
// reprojection error to mean anything; these are measured here, and a solution the SfM itself
// found degenerate (SfmResult::degenerate: centres on a line the two-view directions contradict)
// is not well constrained either.
#include <string>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/sfm/global_sfm.h"

namespace nerfreg {

struct SfmQualityOptions {
  // Thresholds below which a solution is reported as not well constrained (dbarf poses warns and
  // marks the result). Chosen on rendered scenes with known poses (docs/poses_and_views.md).
  int min_image_side_px = 32;
  int min_points_per_image = 20;
  // Per image, points that 3 or more images see: they tie the image to more than one pair. It
  // replaced a median track length of 2.5, which called the 640x480 orbits of 24-96 photos
  // (results/poses_scale.md, real_poses.md) not well constrained: SIFT's many two-view points put
  // their median at 2 while the poses were within 0.4 deg of the truth. Below the fewest such
  // points an image of those orbits saw (14, at 48 and 96 photos).
  int min_multiview_points_per_image = 10;
  double min_median_triangulation_angle_deg = 1.0;
  void Check() const;  // throws InputError naming the field
};

struct SfmQuality {
  int min_image_side_px = 0;
  int min_points_per_image = 0;            // over posed images
  int min_multiview_points_per_image = 0;  // the same, counting points 3 or more images see
  double median_points_per_image = 0;
  double median_track_length = 0;             // observations per point
  double median_triangulation_angle_deg = 0;  // per point, the widest angle between two of its rays
  // Per posed image (index into the SfM's images), the points it observes; 0 for unposed images.
  std::vector<int> points_per_image;
  // Why the solution is not well constrained, one sentence each; empty when it is.
  std::vector<std::string> problems;
  bool WellConstrained() const { return problems.empty(); }
};

SfmQuality AssessSfm(const SfmResult& result, const std::vector<Camera>& cameras,
                     const SfmQualityOptions& options = {});

// "images of N px on their short side (at least M are needed)" when the smallest side among
// `min_image_side_px` is below options.min_image_side_px, else "": a limit of the pixels that holds
// whatever poses them (AssessSfm adds why it matters to the SfM; dbarf poses uses it for images the
// network posed).
std::string SmallImagesProblem(int min_image_side_px, const SfmQualityOptions& options = {});

}  // namespace nerfreg
