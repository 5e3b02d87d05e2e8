#pragma once
// A view graph from images alone (no poses): which images see the same part of the scene, and
// their relative rotation and translation direction. DBARF chooses each target's source views
// from it, at training AND at test time (the original used ground-truth camera distances at test
// time, spec dbarf.md 9.3), and its relative poses are the classical initialisation that the
// pose graph fuses into global cameras.
//
// SIFT features (OpenCV), Lowe ratio test + mutual consistency, essential matrix by RANSAC or
// USAC (MAGSAC++) on undistorted normalised coordinates, cheirality check (recoverPose). Edge
// weight = inlier count. Pairs that cannot become edges are rejected early (a hypothesis cap from
// min_inliers, no homography after a failed essential matrix): on an orbit most pairs do not
// overlap, and they cost the full 1000 hypotheses otherwise.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/stage_times.h"
#include "nerfreg/viewgraph/focal_estimation.h"
#include "nerfreg/viewgraph/pair_selection.h"

namespace nerfreg {

// How a pair's essential matrix (and its homography) are estimated, both by OpenCV on the putative
// matches.
enum class TwoViewEstimator {
  kRansac,  // cv::RANSAC: up to 1000 hypotheses (2000 for the homography) on a pair with few inliers
  kUsac,    // cv::USAC_MAGSAC: MAGSAC++ scoring, local optimisation, SPRT early rejection of hypotheses
};

// "ransac" or "usac" (the values of --two-view); anything else throws InputError naming --two-view.
TwoViewEstimator ParseTwoViewEstimator(const std::string& name);
std::string TwoViewEstimatorName(TwoViewEstimator estimator);

// How SIFT's descriptors are normalised before they are matched (COLMAP's
// SiftExtraction.normalization), as bytes of 512x the unit vector.
enum class SiftNormalization {
  kL2,      // OpenCV's own: unit length
  kL1Root,  // RootSIFT (Arandjelovic & Zisserman 2012): the square roots of the unit-L1 descriptor
};

// "l1-root" or "l2" (the values of --sift-normalization); anything else throws InputError.
SiftNormalization ParseSiftNormalization(const std::string& name);
std::string SiftNormalizationName(SiftNormalization normalization);

struct ViewGraphOptions {
  int max_features = 4000;           // SIFT keypoints kept per image (strongest first)
  double ratio = 0.8;                // Lowe ratio test
  double ransac_threshold_px = 1.0;  // essential-matrix RANSAC threshold, pixels
  double ransac_confidence = 0.999;
  // The random state of USAC's hypotheses (--seed), the same for every pair. Where pairs have few
  // matches the inlier sets, and through the tracks the poses, change with it: bench/real_poses.sh
  // reports the spread over seeds. cv::RANSAC seeds its own generator.
  unsigned int seed = 0;
  int min_inliers = 30;  // fewer geometric inliers: no edge
  // The essential matrix's estimator (--two-view). USAC, the default: fewer wrong edges, cheaper
  // on pairs that do not overlap and more accurate poses on the orbit and Castle-simu; its own
  // final fit is replaced by a refinement (refine_ransac), which handles planar scenes. On
  // low-texture scenes its extra edges can give a wrong SfM; the SfM's check of its centres against
  // the edges' directions (sfm/global_sfm.h, CheckEdgeDirections) reports it, and auto then puts
  // it to its photometric check (docs/poses_and_views.md).
  TwoViewEstimator estimator = TwoViewEstimator::kUsac;
  // USAC's relative pose is refined on its inliers (Levenberg-Marquardt on the Cauchy-robust
  // Sampson distances), and the inliers chosen again with it, in place of USAC's own final
  // least-squares fit: an eight-point fit, which a planar scene leaves undetermined. true: RANSAC's
  // model (its best minimal sample's) is refined alike; false keeps the default path as it was.
  bool refine_ransac = false;
  // Early rejection of pairs that cannot become edges. (1) The hypotheses drawn are capped at the
  // number that finds, with ransac_confidence, an all-inlier sample when just min_inliers of the
  // pair's matches are inliers: a pair of 22 matches needs 57 for its essential matrix, not 1000;
  // more hypotheses only look for models with too few inliers. (2) A pair whose essential matrix
  // has fewer than min_inliers inliers is no edge whatever its homography says (a homography's
  // inliers also fit the essential matrix [t]x R of its rotation for any t), so the homography is
  // fitted only to pairs that pass, and its hypotheses are capped as in (1) for the inliers that
  // would make the pair planar (0.8 of the essential matrix's), and at most 500 (view_graph.cc,
  // kMaxEarlyHomographyIterations). false: 1000 / 2000 hypotheses and every homography fitted.
  bool early_rejection = true;
  // RootSIFT's distances weigh the histograms' small bins more, so views further apart match, and
  // the tracks that span an orbit hold its shape (more accurate poses at 24, 96 and 192 views of
  // the photo-like orbit, a little less at 48: docs/notes/2026-11-30-orbit-accuracy.md). dbarf
  // poses uses it by default; the SfM behind the DBARF training and evaluation commands keeps L2,
  // with which their results were measured.
  SiftNormalization normalization = SiftNormalization::kL2;
  // OpenCV SIFT's contrast threshold (its default 0.04; COLMAP's peak threshold 0.02 / 3 layers
  // equals 0.02 here). Small, dark renders need a lower one to give more than a few dozen keypoints.
  double contrast_threshold = 0.04;
  // An image that gives fewer than sparse_image_keypoints keypoints at contrast_threshold is
  // searched again at this lower threshold (0: never), and an image enlarged before SIFT (a small
  // one, see upsample) is searched at it alone. Textured photos keep their stronger keypoints,
  // which repeat across views and are fewer to match; faint and small images keep all they have.
  // The second search costs one more scale space on the faint photos only.
  double sparse_contrast_threshold = 0;
  int sparse_image_keypoints = 300;
  // Images are enlarged by this factor (bilinear) before SIFT, and keypoints mapped back: more
  // keypoints, better localised, on small images. 1 = as they are.
  int upsample = 1;
  // ... but only while the enlarged image's longer side stays within this many pixels (0: always):
  // photo-sized images have features enough, and SIFT's cost grows with the pixel count.
  int upsample_max_side = 0;
  // Self-calibration: the focal length of each camera group is estimated from the pairs'
  // fundamental matrices (focal_estimation.h) before the essential matrices are, where the
  // estimate is distinct; elsewhere the cameras' own (prior) focal length stays.
  bool estimate_focal = false;
  FocalEstimationOptions focal_estimation;
  // Which pairs are matched (pair_selection.h: --pairs exhaustive|sequential|retrieval|auto).
  PairSelectionOptions pairs;
  void Check() const;  // throws std::invalid_argument
};

// Two views related by an essential matrix: x_in_j = j_from_i * x_in_i with |t| = 1 (the scale
// of a two-view translation is unknown), or, for photos taken from one spot (panoramic), by a
// rotation alone: then t = 0 (no direction; averaging and positioning use only the rotation).
struct ViewGraphEdge {
  int i = 0;
  int j = 0;
  int num_matches = 0;  // after the ratio and mutual tests
  int num_inliers = 0;  // essential-matrix inliers in front of both cameras (homography's if panoramic)
  Rigid3d j_from_i;
  // The inlier correspondences (keypoint index in image i, keypoint index in image j), indices
  // into ViewGraph::keypoints[i] and [j]: what tracks are built from (sfm/tracks.h).
  std::vector<std::pair<int, int>> inlier_matches;
  // 0 also where none was estimated; where fitted only for the planar check, counted among the
  // essential matrix's inliers.
  int num_homography_inliers = 0;
  bool panoramic = false;  // a pure rotation: the rotation from the homography, no translation
  bool planar = false;     // a planar scene: the pose from the homography's decomposition
};

struct ViewGraph {
  std::vector<std::string> names;  // one per image
  // The intrinsics the edges were estimated with, one per image: the given cameras, with the
  // estimated focal lengths where ViewGraphOptions::estimate_focal found them.
  std::vector<Camera> cameras;
  std::vector<ViewGraphEdge> edges;
  // Per image, the SIFT keypoints' image coordinates (pixels, centre of pixel (c, r) at
  // (c + 0.5, r + 0.5)), indexed by ViewGraphEdge::inlier_matches.
  std::vector<std::vector<Eigen::Vector2d>> keypoints;

  // The k neighbours of image i with the most inliers, best first.
  std::vector<int> Neighbors(int i, int k) const;
  // Images with no edge at all (reported by name and left out by callers).
  std::vector<int> Isolated() const;
  const ViewGraphEdge* FindEdge(int i, int j) const;
};

// The enlargement applied to images whose longer side is max_side pixels (upsample or 1).
int EffectiveUpsample(const ViewGraphOptions& options, int max_side);

// The grey level SIFT sees at pixel (x, y), in [0, 1] before clamping: the luma (0.299, 0.587,
// 0.114) of RGB, RGBA composited over white, a grey image's own. Code that samples the images
// again for the keypoints (sfm's keypoint refinement) reads the same levels.
template <typename ImageT>  // Image or PackedImage
inline float FeatureGrey(const ImageT& im, int x, int y) {
  if (im.channels < 3) return im.at(x, y, 0);
  const float v = 0.299f * im.at(x, y, 0) + 0.587f * im.at(x, y, 1) + 0.114f * im.at(x, y, 2);
  return im.channels == 4 ? v * im.at(x, y, 3) + (1 - im.at(x, y, 3)) : v;
}

// One image's SIFT keypoints and descriptors, row k of each the same keypoint.
struct SiftFeatures {
  // Image coordinates in pixels (centre of pixel (c, r) at (c + 0.5, r + 0.5)).
  std::vector<Eigen::Vector2d> keypoints;
  SiftDescriptors descriptors;  // 128 bytes a keypoint, normalised by ViewGraphOptions::normalization
};

// OpenCV SIFT on the image's grey levels (enlarged by EffectiveUpsample first), the
// options.max_features strongest keypoints at options.contrast_threshold, or at
// options.sparse_contrast_threshold where the image is enlarged or the first gives too few
// (sparse_image_keypoints).
SiftFeatures ExtractSiftFeatures(const Image& image, const ViewGraphOptions& options);
SiftFeatures ExtractSiftFeatures(const PackedImage& image, const ViewGraphOptions& options);

// How MatchDescriptors multiplies the descriptors. Both give the same integers, so the same matches.
enum class DescriptorProduct {
  kAuto,   // kInt8 where it is exact on this CPU, else kFloat
  kFloat,  // the BLAS's sgemm on the bytes as floats
  kInt8,   // oneDNN's u8 x s8 product with 32-bit sums: ~4x sgemm's rate with AVX-512 VNNI; exact
           // only with VNNI (Int8DescriptorProductIsExact), and refused (std::logic_error) elsewhere
};

// Whether DescriptorProduct::kInt8 is exact on this CPU (checked once, on a product that saturates
// without VNNI). Its first call also caps oneDNN at AVX-512 VNNI (below AMX, 3.3x slower on the
// matcher's products) unless ONEDNN_MAX_CPU_ISA is set: a process-wide setting.
bool Int8DescriptorProductIsExact();

// Mutual nearest neighbours (Euclidean) passing Lowe's ratio test in both directions: pairs
// (row of a, row of b). One GEMM of the descriptor dot products per pair.
std::vector<std::pair<int, int>> MatchDescriptors(const SiftDescriptors& a, const SiftDescriptors& b, double ratio,
                                                  DescriptorProduct product = DescriptorProduct::kAuto);

// One pair's two-view geometry from its putative matches (rows of keypoints_i, keypoints_j):
// essential matrix, cheirality, and the homography test for panoramic pairs. keypoints_*: the
// images' keypoints in normalised image coordinates (Camera::CamFromImg's x / z, y / z);
// threshold_px / focal_px: the RANSAC threshold in normalised units. nullopt: fewer than
// options.min_inliers inliers (no edge). Deterministic: USAC draws from options.seed, cv::RANSAC
// seeds its own generator. The edge's i, j are left 0.
std::optional<ViewGraphEdge> EstimateTwoViewGeometry(const std::vector<Eigen::Vector2d>& keypoints_i,
                                                     const std::vector<Eigen::Vector2d>& keypoints_j,
                                                     const std::vector<std::pair<int, int>>& matches, double focal_px,
                                                     const ViewGraphOptions& options);

// Throws InputError naming the image when an image's size differs from its camera's, or, with
// `equal_sizes`, from the first image's (the networks stack images; the SfM takes any sizes).
void CheckImageSizes(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, bool equal_sizes = true);
void CheckImageSizes(const std::vector<PackedImage>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, bool equal_sizes = true);

// Builds the graph over the pairs options.pairs selects (or the given `pairs`, i < j). images: float or packed
// (grey or colour), any sizes; cameras: one per image (intrinsics only; the focal lengths are
// priors with options.estimate_focal). camera_group: per image, the camera whose focal length it
// shares when it is estimated (empty: one group per image size). Throws InputError naming the
// image when an image's size differs from its camera's. times (optional): the stages "features",
// "matching" (descriptors), "focal estimation" (when on) and "geometry" (essential matrices) are
// recorded there. The PackedImage overload gives the same graph for the same pixels.
ViewGraph BuildViewGraph(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                         const std::vector<std::string>& names, const ViewGraphOptions& options,
                         StageTimes* times = nullptr, const std::vector<int>& camera_group = {},
                         const std::vector<std::pair<int, int>>& pairs = {});
ViewGraph BuildViewGraph(const std::vector<PackedImage>& images, const std::vector<Camera>& cameras,
                         const std::vector<std::string>& names, const ViewGraphOptions& options,
                         StageTimes* times = nullptr, const std::vector<int>& camera_group = {},
                         const std::vector<std::pair<int, int>>& pairs = {});

}  // namespace nerfreg
