#pragma once
// Poses of unposed images with known intrinsics: classical global structure from motion, the
// initialisation DBARF's networks refine (issue 5; `nerfreg dbarf poses`).
//
//   view graph (SIFT, essential matrices, viewgraph/view_graph.h)
//   -> rotation averaging (robust, spanning-tree init; rotation_averaging.h)
//   -> tracks (union-find over the inlier matches of rotation-consistent edges; tracks.h)
//   -> global positioning: camera centres and points together from the rays, from a random start
//      (global_positioning.h, as GLOMAP / COLMAP 4), or translation averaging of the pairwise
//      directions (translation_averaging.h; the former default, kept for comparison)
//   -> rounds of triangulation + bundle adjustment (pixels, Huber), the first with rotations held,
//      each round re-triangulating every track with a tighter reprojection threshold, so
//      observations rejected with rough poses come back once the poses are good; the last rounds
//      refine the intrinsics when asked (self-calibration; triangulation.h, bundle_adjustment.h).
//      The rounds before the last adjust a subset of the points spread over every image; self-
//      calibrating, the last refines the intrinsics on that subset before all points: the focal
//      length's shallow valley costs many iterations, which then run over a fraction of the
//      observations.
//   -> a check for a collapsed solution (camera centres that coincide although the two images' own
//      matches show parallax): solved again by global positioning from another random start, and
//      images still collapsed are left unposed with the reason. Centres that contradict the edges'
//      two-view directions (on a line, or reflected through the scene; CheckEdgeDirections) are
//      reported (SfmResult::degenerate): solving again did not change them.
//
// The output frame: the first posed image's camera is the identity (world = its camera frame,
// OpenCV axes) and the scale makes the mean distance of the other posed cameras to it 1. Images
// are only known up to a similarity, so evaluations align by Sim(3) anyway.
#include <string>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/sfm/bundle_adjustment.h"
#include "nerfreg/sfm/global_positioning.h"
#include "nerfreg/sfm/keypoint_refinement.h"
#include "nerfreg/sfm/rotation_averaging.h"
#include "nerfreg/sfm/tracks.h"
#include "nerfreg/sfm/translation_averaging.h"
#include "nerfreg/sfm/triangulation.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/stage_times.h"
#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {

// The view graph settings for posing: images enlarged 2x before SIFT (as COLMAP's first octave -1
// does) up to 1000 px; a SIFT contrast threshold of 0.01 (half of COLMAP's, which is 0.02 in
// OpenCV's units), and 0.005 on enlarged images and those that give fewer than 300 keypoints at
// 0.01 (DBARF's inputs are often small, dark renders; low-texture photos). On a textured
// photo-like forward set, before keypoint refinement, 0.005 gave 3x the keypoints of 0.01 and
// 1.5-1.6x the time for 0.048-0.057 deg instead of 0.075-0.097 (24-96 views).
ViewGraphOptions SfmViewGraphDefaults();

// How camera centres are found once orientations are known.
enum class SfmPositioning {
  kGlobalPositioning,     // cameras and points from the rays (global_positioning.h)
  kTranslationAveraging,  // pairwise directions alone (translation_averaging.h)
};

struct SfmOptions {
  ViewGraphOptions view_graph = SfmViewGraphDefaults();
  RotationAveragingOptions rotation;
  SfmPositioning positioning = SfmPositioning::kGlobalPositioning;
  GlobalPositioningOptions global_positioning;
  TranslationAveragingOptions translation;
  TrackOptions tracks;
  BundleAdjustmentOptions bundle_adjustment;
  // Reprojection thresholds (pixels) of the triangulation rounds, loose to tight: the first
  // triangulates from the averaged poses (a few pixels off at 128x96), the last sets the final
  // observations. One bundle adjustment follows each round.
  std::vector<double> round_reprojection_error_px = {8.0, 3.0, 2.0};
  double min_triangulation_angle_deg = 1.0;  // points seen under a smaller angle are not kept
  // After the first round, the tracks are built again from every edge's matches that agree with
  // the solved poses to this many pixels (epipolar, Sampson), also the edges rotation averaging
  // left out; 0 keeps the first tracks throughout.
  double reverify_matches_px = 2.0;
  // Self-calibration in the bundle adjustments after the first round: the focal length and the
  // radial distortion (k1, k2) of each camera group.
  bool refine_focal = false;
  bool refine_distortion = false;
  // The rounds before the last adjust only a subset of the points spread over every image
  // (SpreadPointSubset: cells per image side, points per cell): their poses only serve to verify
  // the matches and triangulate again. Self-calibrating, the last round also refines the
  // intrinsics with the poses on that subset first, re-triangulates every track and then adjusts
  // all points (intrinsics refined again). 0 cells adjusts all points in every round.
  // Calibrated, the subset halved the adjustments' time on 96 and 192 views (6.4 -> 3.5 s on 192
  // forward-facing ones) for the same poses within noise (docs/poses_and_views.md).
  int subset_cells = 8;
  int subset_per_cell = 4;
  // Camera centres closer than this fraction of the centres' rms spread count as coincident (a
  // collapsed solution: no capture has two photos from one point); 0 turns the check off.
  double collapse_fraction = 0.01;
  int collapse_retries = 2;  // re-solves from another random start before images are left out
  // A solution whose centres contradict the two-view directions of the edges it was solved from
  // (CheckEdgeDirections: their median angle above this, degrees, over at least 3 edges) is
  // reported as degenerate (SfmResult::degenerate). 0 turns the check off.
  double max_edge_direction_residual_deg = 40.0;
  // Self-calibration from a guessed focal length (refine_focal, a prior from the image size): the
  // solve runs from each of these multiples of the cameras' focal lengths, the edges measured again
  // at each (MeasureEdgesWithIntrinsics), two at a time, and the solution whose points keep the
  // most observations is kept: a focal guessed from the image size can start the solve in a wrong
  // minimum, which its own checks do not see, and a start elsewhere leaves
  // (docs/poses_and_views.md, self-calibration). Empty or one value: one start.
  std::vector<double> focal_starts;
  // With focal_starts: one more start at this multiple, solved only where the starts end with as
  // much support at focal lengths further apart than the covariance's standard deviation (the
  // photos leave the focal free; kFocalSpreadComparableObservations): it samples that valley below
  // the prior too, and the spread reports it. Measured: Castle-simu (truth 700 px) ends at 743.0,
  // 774.1 and, from 0.7x, 705.6 px with 0.3 % fewer observations than the kept start; spider24
  // (888.9) at 915.8, 905.0 and 892.4; on the real cube the two starts agree (596.4 px) and it is
  // not solved (a third start there took 19.0 s against 6.9). 0: none.
  double focal_start_below = 0.7;
  // With focal_starts: a prior worth more than the photos where they leave the focal free (an EXIF
  // focal length). Free: the starts end apart with as much support (FocalStartsDisagree: where the
  // solve ends is the start's choice), or the kept start's standard deviation (widened by the
  // starts' spread) is above this fraction of its focal for some camera. There the SfM is solved
  // once more with every focal held at its prior (focal_starts' first multiple should be 1), the
  // distortion still refined, and that solution is returned (SfmResult::focal_prior_held);
  // focal_start_below is then not solved. 0: never. Measured with an EXIF focal (35 mm equivalent,
  // docs/poses_and_views.md): on Castle-simu (EXIF 0.95 % below the truth) the EXIF focal is held
  // for 4 seeds of 5, where refined it ended 1.2-2.6 % above; spider24's starts agree (1.0 %), so a
  // prior 4 % off is still refined to within 1 %.
  double hold_focal_prior_above = 0;
  // PoseImages: each track's keypoints aligned with one another on the images before the solve
  // (RefineTrackKeypoints, on the tracks of every edge).
  bool refine_keypoints = true;
  KeypointRefinementOptions keypoint_refinement;
  void Check() const;  // throws std::invalid_argument
};

struct SfmResult {
  std::vector<Rigid3d> cam_from_world;  // one per image; identity where !posed
  std::vector<bool> posed;
  std::vector<std::string> not_posed;  // names of the images left out (no edge, or outside the
                                       // largest consistent component, or collapsed)
  // Per image, why it is not posed ("" where posed): "no consistent two-view geometry", "too few
  // tracks", "its camera centre coincides with NAME's (a collapsed solution)".
  std::vector<std::string> not_posed_reason;
  std::vector<Camera> cameras;  // the intrinsics used, refined where asked
  // Self-calibrating: per image, the standard deviation (pixels) of its group's refined focal
  // length (BundleAdjustmentOptions::estimate_focal_stddev; infinity where the data leave it
  // free); empty when the focal was not refined.
  std::vector<double> focal_stddev_px;
  // SfmOptions::hold_focal_prior_above: the focal lengths are the priors, held, because the photos
  // left them free; focal_stddev_px is then the kept start's (widened by the starts' spread).
  bool focal_prior_held = false;
  std::vector<SfmPoint> points;  // the triangulated tracks, elements index view_graph.keypoints
  int num_points = 0;
  int num_observations = 0;               // the points' elements, all together
  double mean_reprojection_error_px = 0;  // over the final observations
  // The graph the poses came from, with its keypoints; self-calibrated, its edges measured again
  // with the refined intrinsics (MeasureEdgesWithIntrinsics), which view_graph.cameras then holds.
  ViewGraph view_graph;
  int num_edges_used = 0;  // edges consistent with the averaged rotations
  // Per view_graph edge: whether it was one of those (the edges the tracks and positions came from).
  std::vector<bool> edge_used;
  int num_collapse_resolves = 0;  // solutions found collapsed and solved again
  // Why the solution is degenerate although its images are posed: "" or, where the centres
  // contradict the edges' two-view directions (CheckEdgeDirections), a sentence saying so
  // (sfm_quality.h reports it; dbarf poses' auto then puts the solution to its test).
  std::string degenerate;
  double seconds_view_graph = 0;
  double seconds_sfm = 0;  // averaging, triangulation and bundle adjustment
  // Per stage: features, matching, geometry (PoseImages only), rotation averaging, tracks,
  // positioning, triangulation, bundle adjustment (all rounds and attempts together).
  StageTimes times;
};

// Self-calibration from several focal starts (SfmOptions::focal_starts): starts whose solutions keep
// nearly as many observations as the kept one's (at least this fraction) are as well supported by
// the photos, and where they end at other focal lengths the photos do not tell those apart, however
// small the covariance at the kept one. Measured (2026-11-29): on Castle-simu (40 renders, focal
// 700 px, a motion close to a critical one) the second start kept 0.2-1.2 % fewer observations and
// ended 2.6-5.8 % away in focal, where the covariance said 0.7 % and the kept focal was 3-6 % off;
// on the real cube a start that fell into a wrong minimum (479 px against 596) kept 3.7 % fewer.
constexpr double kFocalSpreadComparableObservations = 0.98;

// Widens each image's focal_stddev_px in (*results)[kept] to at least the sample standard deviation
// of its focal length over the results with comparable support (above); `starts` only for the log.
// Nothing changes where fewer than two are comparable or the kept result has no standard deviations.
void WidenFocalStddevBySpread(int kept, const std::vector<double>& starts, std::vector<SfmResult>* results);

// Whether, for some image, the focal lengths of the results with comparable support (above) to the
// one with the most observations have a larger sample standard deviation than that one's
// focal_stddev_px: the photos leave the focal free, and SfmOptions::focal_start_below is solved.
bool FocalStartsDisagree(const std::vector<SfmResult>& results);

// From a built view graph (used directly by tests with synthetic correspondences). cameras: one
// per graph image; camera_group: per image, the group whose intrinsics it shares when they are
// refined (empty: all one group if the cameras are equal, else one each). Throws
// std::invalid_argument on inconsistent sizes.
SfmResult RunGlobalSfm(const ViewGraph& graph, const std::vector<Camera>& cameras, const SfmOptions& options,
                       const std::vector<int>& camera_group = {});

// From images: builds the view graph, then RunGlobalSfm. Throws InputError naming the file when
// there are fewer than 3 images or their sizes differ (from each other or from their camera).
SfmResult PoseImages(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, const SfmOptions& options,
                     const std::vector<int>& camera_group = {});
SfmResult PoseImages(const std::vector<PackedImage>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, const SfmOptions& options,
                     const std::vector<int>& camera_group = {});

// Per image, another posed image whose camera centre coincides with its own (closer than
// `fraction` of the root-mean-square spread of the posed centres), or -1. A solution with such
// images may have collapsed (seen from the SfM on repetitive texture and from the network on
// low-texture images); photos taken from one spot do this too, which is why RunGlobalSfm only
// calls it a collapse where the two images' own matches show parallax.
std::vector<int> CoincidentCentres(const std::vector<Rigid3d>& cam_from_world, const std::vector<bool>& posed,
                                   double fraction = 0.01);

// Per image whose centre coincides with image coincident[k]'s (CoincidentCentres; -1: none),
// whether the two images' own matches in `graph` show parallax at cam_from_world's rotations (the
// rays' median angle above 1 deg), which two photos taken from one spot cannot: a collapsed
// solution. False where the graph has no edge between them (nothing tells).
std::vector<bool> CollapsedCentres(const ViewGraph& graph, const std::vector<Camera>& cameras,
                                   const std::vector<Rigid3d>& cam_from_world, const std::vector<int>& coincident);

// How far the solved camera centres contradict the view graph's own two-view geometry: per edge
// between posed images, the angle between the edge's translation direction (from its essential
// matrix, rotated into the world frame by the solved rotation of its first image) and the
// direction between the two solved centres. Global positioning can converge to a wrong solution at
// a sub-pixel reprojection error when tracks are short and rays nearly parallel (low-texture
// renders): the centres on a line, or reflected through the scene; most edges then disagree with
// it by tens of degrees. Photos taken along a rail have their centres on a line too, but there the
// pairs' directions run along it and agree.
struct EdgeDirectionCheck {
  // Median over the measured edges of that angle (degrees, 0..180).
  double median_residual_deg = 0;
  // Root-mean-square distance of the posed centres from their principal line over their rms
  // spread along it (0: exactly on a line; infinity with fewer than 3 posed centres): said in the
  // report, not tested.
  double off_line_fraction = 0;
  int num_edges = 0;          // edges with a translation direction that were measured
  bool contradicted = false;  // median_residual_deg > the maximum, over at least 3 edges
};
// Measures each non-panoramic edge of `graph` whose images' intrinsics differ in `cameras` from
// graph->cameras (those the edge was estimated with) again on its inlier matches, refined from its
// own pose (RefineRelativePose, 1 px), and sets graph->cameras = cameras. An essential matrix's
// rotation moves with the focal length it is made with: self-calibrated on ViSP's real cube from a
// prior 23 % off, the edges measured with the prior put well-posed images 4-8 deg off their own
// edges. RunGlobalSfm calls it once the intrinsics are refined.
void MeasureEdgesWithIntrinsics(const std::vector<Camera>& cameras, ViewGraph* graph);

// edge_used: per graph edge, whether to measure it (empty: all). Panoramic edges (no direction)
// and edges whose solved centres coincide are skipped; with fewer than 3 edges measured nothing
// is contradicted.
EdgeDirectionCheck CheckEdgeDirections(const std::vector<Rigid3d>& cam_from_world, const std::vector<bool>& posed,
                                       const ViewGraph& graph, const std::vector<bool>& edge_used,
                                       double max_median_residual_deg);

}  // namespace nerfreg
