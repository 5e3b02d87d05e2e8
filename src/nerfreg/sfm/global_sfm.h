#pragma once
// Poses of unposed images with known intrinsics: classical global structure from motion, the
// initialisation DBARF's networks refine (issue 5; `nerfreg dbarf poses`).
//
//   view graph (SIFT, essential matrices, viewgraph/view_graph.h)
//   -> rotation averaging (robust, spanning-tree init; rotation_averaging.h)
//   -> translation averaging of the unit directions (translation_averaging.h)
//   -> tracks (union-find over the inlier matches of rotation-consistent edges; tracks.h)
//   -> rounds of triangulation + bundle adjustment (pixels, Huber), each round re-triangulating
//      every track with a tighter reprojection threshold, so observations rejected with rough
//      poses come back once the poses are good (triangulation.h, bundle_adjustment.h).
//
// The output frame: the first posed image's camera is the identity (world = its camera frame,
// OpenCV axes) and the scale makes the mean distance of the other posed cameras to it 1. Images
// are only known up to a similarity, so evaluations align by Sim(3) anyway.
#include <string>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/sfm/bundle_adjustment.h"
#include "nerfreg/sfm/rotation_averaging.h"
#include "nerfreg/sfm/tracks.h"
#include "nerfreg/sfm/translation_averaging.h"
#include "nerfreg/sfm/triangulation.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/stage_times.h"
#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {

// The view graph settings for posing: COLMAP's SIFT contrast threshold, and images enlarged 2x
// before SIFT (as COLMAP's first octave -1 does), since DBARF's inputs are often small renders.
ViewGraphOptions SfmViewGraphDefaults();

struct SfmOptions {
  ViewGraphOptions view_graph = SfmViewGraphDefaults();
  RotationAveragingOptions rotation;
  TranslationAveragingOptions translation;
  TrackOptions tracks;
  BundleAdjustmentOptions bundle_adjustment;
  // Reprojection thresholds (pixels) of the triangulation rounds, loose to tight: the first
  // triangulates from the averaged poses (a few pixels off at 128x96), the last sets the final
  // observations. One bundle adjustment follows each round.
  std::vector<double> round_reprojection_error_px = {8.0, 3.0, 2.0};
  double min_triangulation_angle_deg = 1.0;  // points seen under a smaller angle are not kept
  void Check() const;                        // throws std::invalid_argument
};

struct SfmResult {
  std::vector<Rigid3d> cam_from_world;  // one per image; identity where !posed
  std::vector<bool> posed;
  std::vector<std::string> not_posed;  // names of the images left out (no edge, or outside the
                                       // largest consistent component)
  std::vector<SfmPoint> points;        // the triangulated tracks, elements index view_graph.keypoints
  int num_points = 0;
  double mean_reprojection_error_px = 0;  // over the final observations
  ViewGraph view_graph;                   // the graph the poses came from, with its keypoints
  int num_edges_used = 0;                 // edges consistent with the averaged rotations
  double seconds_view_graph = 0;
  double seconds_sfm = 0;  // averaging, triangulation and bundle adjustment
  // Per stage: features, matching, geometry (PoseImages only), rotation averaging, translation
  // averaging, tracks, triangulation, bundle adjustment (all rounds together).
  StageTimes times;
};

// From a built view graph (used directly by tests with synthetic correspondences). cameras: one
// per graph image. Throws std::invalid_argument on inconsistent sizes.
SfmResult RunGlobalSfm(const ViewGraph& graph, const std::vector<Camera>& cameras, const SfmOptions& options);

// From images: builds the view graph, then RunGlobalSfm. Throws InputError naming the file when
// there are fewer than 3 images or their sizes differ (from each other or from their camera).
SfmResult PoseImages(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, const SfmOptions& options);

}  // namespace nerfreg
