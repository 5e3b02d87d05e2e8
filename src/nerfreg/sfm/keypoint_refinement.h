#pragma once
// Keypoints of one track moved onto one another's image patch before the poses are solved
// (pixel-perfect SfM's keypoint adjustment, Lindenberger et al. 2021, with grey levels in place of
// learned features). SIFT places a keypoint at the extremum of its own image's difference of
// Gaussians: under a change of viewpoint, noise and JPEG, that extremum lands a few tenths of a
// pixel apart in each image, and the bundle adjustment reads those tenths as pose.
// Each observation's window is aligned with the same scene patch in the track's most alike view by
// an affine warp (inverse-compositional Gauss-Newton on grey levels), so that the observations of
// a track agree with one another. Measured (docs/poses_and_views.md): results/poses_scale.md's
// forward-facing views 0.075-0.097 -> 0.059-0.063 deg from the truth, the real cube's
// reprojection error 0.177 -> 0.090 px; Castle-simu (untextured) worse, 0.253 -> 0.334 deg.
#include <vector>

#include <Eigen/Core>

#include "nerfreg/sfm/tracks.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

struct KeypointRefinementOptions {
  int window_px = 15;         // side of the aligned patch (odd), in the image's pixels
  double max_shift_px = 2.0;  // an alignment moving a keypoint further is refused (SIFT's position kept)
  // Gauss-Newton steps, and the step that ends them (moving the window's centre less than this):
  // 8 and 0.02 took half the time of 20 and 0.001 for the same poses (forward-facing renders).
  int max_iterations = 8;
  double epsilon_px = 0.02;
  double max_distortion = 0.3;  // refused where the warp's linear part leaves the identity by more
  // Refused where the aligned patches' zero-mean normalised correlation is lower (-1: never).
  double min_correlation = 0.9;
  int num_threads = 2;  // at most the hardware's
  void Check() const;   // throws std::invalid_argument
};

struct KeypointRefinementSummary {
  int num_tracks = 0;          // tracks refined (2 images or more)
  int num_moved = 0;           // observations moved
  int num_refused = 0;         // observations whose alignment failed the options' checks
  double median_shift_px = 0;  // over the moved observations
};

// Moves the keypoints (keypoints[image][k], pixel centres at +0.5 as ViewGraph's) of every track
// onto one another: the track's observations as a tree along its images' strongest view-graph
// edges (most inliers), rooted where the edges are strongest, each observation aligned with its
// parent's (already aligned) window. images: those the keypoints were extracted from, in the same
// order. A keypoint in no track, or refused, keeps its position. Throws std::invalid_argument on
// counts that differ or options that fail Check().
KeypointRefinementSummary RefineTrackKeypoints(const std::vector<Image>& images, const ViewGraph& graph,
                                               const std::vector<Track>& tracks,
                                               const KeypointRefinementOptions& options,
                                               std::vector<std::vector<Eigen::Vector2d>>* keypoints);
KeypointRefinementSummary RefineTrackKeypoints(const std::vector<PackedImage>& images, const ViewGraph& graph,
                                               const std::vector<Track>& tracks,
                                               const KeypointRefinementOptions& options,
                                               std::vector<std::vector<Eigen::Vector2d>>* keypoints);

}  // namespace nerfreg
