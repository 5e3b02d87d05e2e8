// Poses of unposed images (`nerfreg dbarf poses --method`) by the classical SfM, by the DBARF
// pose network, or by the SfM completed by the network.
//
//  classical: sfm/global_sfm.h alone (SIFT view graph, averaging, triangulation, bundle adjustment).
//  network:   the network poses every image; no SfM. Each image is a target once, its sources its
//             neighbours (view-graph neighbours by inliers when images are matched, topped up with
//             appearance neighbours when it has too few, so an image without any edge still gets
//             sources); the network starts from the identity (pose_init "network") and its relative
//             pose src_from_tgt is one edge per (target, source). An edge seen from both ends gives
//             two measurements. sfm/relative_pose_averaging.h turns them into global cameras
//             (robust rotation then translation averaging), instead of the original's chaining
//             along a maximum spanning tree, which lets one bad edge move a whole subtree.
//  auto:      classical; where it leaves images unposed, the network poses each of them against
//             its best posed neighbours (relative poses composed with their SfM cameras, the
//             network's translation scale fitted to the SfM on the edges between those neighbours),
//             so the classical cameras are kept untouched where SfM succeeded. With too few SfM
//             cameras to register against (< 3, or no depth range) it falls back to network.
//
// Per-image confidence (ImagePoseConfidence), in the same unit for every method: how far the
// image's pairwise measurements disagree with the accepted poses, as a median rotation angle over
// `edges` measurements:
//   sfm:                 its view-graph edges (essential matrices) to other SfM-posed images that
//                        the solution was made from (SfmResult::edge_used), against the final
//                        cameras; plus its triangulated observations and their mean reprojection
//                        error. The edges rotation averaging left out are counted, not checked:
//                        on a real capture they are wrong matches (Castle-simu's wide pairs,
//                        matched on a logo's repeated pattern) and outvoted right poses.
//   network (network):   its view-graph edges (essential matrices) against the averaged cameras
//                        where images were matched and it has any (an independent check: a network
//                        wrong the same way everywhere agrees with itself around every cycle); else
//                        its network edges (as target or source), a cycle-consistency check.
//   network (auto):      the network's relative rotation between two of its posed sources (through
//                        the image: b_from_u * a_from_u^-1) against the SfM's, per source pair: the
//                        network checked on edges whose answer is known.
// The same for the translation directions (direction_residual_deg). An image is low-confidence
// when it has no such measurement, its residuals exceed low_confidence_deg (rotation) or
// low_confidence_direction_deg (direction), or (sfm) it has fewer than low_confidence_observations
// observations.
#pragma once

#include <torch/torch.h>

#include <string>
#include <utility>
#include <vector>

#include "nerfreg/dbarf/photometric_bundle_adjustment.h"
#include "nerfreg/dbarf/pose_depth_net.h"
#include "nerfreg/dbarf_data/posed_images.h"
#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/sfm/global_sfm.h"
#include "nerfreg/sfm/relative_pose_averaging.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/stage_times.h"

namespace nerfreg {

struct NetworkPosesOptions {
  int num_sources = 5;  // sources per target (the network was trained with 5 +- 2)
  // Images with fewer view-graph neighbours than this get appearance neighbours up to num_sources.
  int min_graph_neighbours = 2;
  // method network: match images (SIFT view graph) to choose sources; false: appearance alone
  // (no SIFT at all).
  bool match_images = true;
  // method network: the depth range the network predicts within (no triangulated points to measure
  // it), in the units of the scenes it was trained on (the classical frame: mean distance of the
  // cameras to the first one 1). method auto uses the SfM's range instead.
  // The defaults are typical of the classical output on 20-view forward-facing 128x96 renders.
  double near = 7.0, far = 40.0;
  // method network: more passes after the first, each starting the network from the relative poses
  // of the cameras averaged from the last (what weights trained to refine cameras expect).
  int refine_passes = 0;
  // Images wider than this are shrunk to it (area average, intrinsics scaled alike) before the
  // network sees them: the weights were trained on 128 x 96 renders, and at 320 x 240 their
  // translations collapse to nothing. 0: as they are.
  int max_width = 128;
  // Weight of the view graph's essential-matrix edges averaged together with the network's edges
  // (each network edge weighs 1; 0: the network's edges alone, as --method network). Method auto
  // uses them where the SfM poses too few images to register against: two images the matcher
  // relates then keep their accurate relative rotation and direction, and the network places the
  // rest around them.
  double graph_edge_weight = 0;
  RelativePoseAveragingOptions averaging;
  // method network: after the averaging, a photometric bundle adjustment of all cameras and the
  // network's depths over the (target, source) pairs the network ran on
  // (photometric_bundle_adjustment.h; no keypoints, so no SIFT even where images were matched).
  bool bundle_adjust = false;
  PhotometricBundleAdjustmentOptions photometric_ba;
  void Check() const;  // throws InputError naming the option
};

struct ImagePosesOptions {
  std::string method = "auto";  // classical | network | auto
  std::string weights;          // DBARF weights (network, auto); loaded only when needed
  SfmOptions sfm;
  // Per image, the camera group whose intrinsics it shares when the SfM refines them (empty: one
  // group per distinct camera).
  std::vector<int> camera_group;
  NetworkPosesOptions network;
  // Method auto, where the SfM poses too few images to register against: the weight of the view
  // graph's essential-matrix edges averaged with the network's (NetworkPosesOptions::graph_edge_weight).
  double auto_graph_edge_weight = 10.0;
  // Method auto, where the SfM posed (nearly) everything but at least this share of its images are
  // low-confidence (their own measurements disagree with their poses; repetition does this),
  // whether or not it calls its solution well constrained (sfm/sfm_quality.h): the network poses
  // all images as well, and the cameras with the lower photometric error over the network's pairs
  // are kept (PhotometricCameraScore). 1 turns the check off.
  double auto_doubt_fraction = 0.25;
  double low_confidence_deg = 5.0;             // rotation residual
  double low_confidence_direction_deg = 30.0;  // direction residual
  int low_confidence_observations = 10;
  torch::Device device = torch::kCPU;  // --device: where the network runs (the images stay on the CPU)
  void Check() const;                  // throws InputError naming the option
};

struct ImagePosesResult {
  std::vector<Rigid3d> cam_from_world;  // per image; identity where !posed
  std::vector<bool> posed;
  std::vector<std::string> posed_by;  // per image: "sfm", "network" or "" (not posed)
  std::vector<ImagePoseConfidence> confidence;
  std::vector<std::string> not_posed, low_confidence;  // image names
  std::vector<std::string> not_posed_reason;           // per image; "" where posed
  // The intrinsics the poses go with, one per image: the given ones, refined where the SfM
  // self-calibrated (SfmOptions::refine_focal / refine_distortion).
  std::vector<Camera> cameras;
  double near = 0, far = 0;  // depth range of the content in the output frame
  // The classical result (auto, classical: its points and view graph; cam_from_world / posed are
  // the final ones); network: the view graph only (keypoints empty when images were not matched).
  SfmResult sfm;
  std::string method_used;  // classical | network | auto (auto may fall back to network)
  // Auto's check of a doubtful SfM (ImagePosesOptions::auto_doubt_fraction): the photometric error
  // of the SfM's and of the network's cameras, and which were kept ("sfm" / "network"); empty and
  // -1 where the check did not run.
  std::string auto_choice;
  double auto_sfm_score = -1, auto_network_score = -1;
  // The SIFT descriptors the view graph matched (SfmOptions::view_graph.normalization).
  SiftNormalization sift_normalization = SiftNormalization::kL2;
  int num_network_edges = 0;  // relative poses predicted by the network
  // The (target, source) pairs the network was run on (once each, whatever the passes): neighbours
  // for dbarf finetune / render where the view graph has none (images without matches).
  std::vector<std::pair<int, int>> network_pairs;
  double seconds_network = 0;
  double seconds = 0;
  // Per stage: "load weights" (network, auto), the SfM's (sfm.times), "network".
  StageTimes times;
};

// Poses images of one size with their intrinsics. Throws InputError naming the file / option on bad
// input (fewer than 3 images, sizes differ, weights unreadable, classical: too few points for a
// depth range; `source`, e.g. the images' folder, is named where no single image is at fault).
ImagePosesResult EstimateImagePoses(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                                    const std::vector<std::string>& names, const ImagePosesOptions& options,
                                    const std::string& source = "images");
ImagePosesResult EstimateImagePoses(const std::vector<PackedImage>& images, const std::vector<Camera>& cameras,
                                    const std::vector<std::string>& names, const ImagePosesOptions& options,
                                    const std::string& source = "images");

// Why method auto leaves an image the network placed beside the SfM's cameras unposed ("" to keep
// it): a problem with the image (textureless, collapsed onto another camera, ...), no edge to the
// posed images to check it by, or its relative rotations / directions to them disagreeing with
// its pose beyond low_confidence_deg / low_confidence_direction_deg. A pose the program itself
// doubts is reported as not posed, never counted.
std::string NetworkPoseRejection(const ImagePoseConfidence& confidence, const ImagePosesOptions& options);

// One line naming every low-confidence image with its confidence, for the warning of dbarf poses:
// "r_004.png (network: rotation 7.2 deg, direction 41 deg over 3 edges; textureless), ...". Empty
// when none is low.
std::string DescribeLowConfidence(const ImagePosesResult& result, const std::vector<std::string>& names);

// ---- The parts, for tests and other callers ----

// Per image, why no method can pose it with confidence, from the pixels (and the view graph when
// images were matched, `matched`): "textureless" (the grey level's standard deviation below
// kTexturelessGreyStd: nothing to match or regress from), "identical to NAME" (every pixel within
// 2/255 of another image's: no baseline, so no direction to it), "unrelated" (no view-graph edge
// and thumbnail similarity below kUnrelatedSimilarity to every other image: most likely another
// scene). Empty where none applies. images: [V, 3, H, W] float32 in [0, 1].
constexpr double kTexturelessGreyStd = 0.01;
constexpr double kUnrelatedSimilarity = 0.3;
std::vector<std::string> ImageInputProblems(const torch::Tensor& images, const ViewGraph& graph, bool matched,
                                            const std::vector<std::string>& names);
// The same from the images as read, one at a time (a set of full-size images is never stacked).
std::vector<std::string> ImageInputProblems(const std::vector<Image>& images, const ViewGraph& graph, bool matched,
                                            const std::vector<std::string>& names);
std::vector<std::string> ImageInputProblems(const std::vector<PackedImage>& images, const ViewGraph& graph,
                                            bool matched, const std::vector<std::string>& names);

// Per image, every other image ranked by the similarity of grey 16 x 12 thumbnails (zero-mean,
// unit-norm, dot product), most similar first: neighbours for images the matcher cannot relate.
// images: [V, 3, H, W] float32.
std::vector<std::vector<int>> AppearanceNeighbours(const torch::Tensor& images);

// Sources of `target`: among `allowed` images (empty: all), its view-graph neighbours by inliers
// (up to num_sources), topped up with appearance neighbours to num_sources when it has fewer than
// min_graph_neighbours of them.
std::vector<int> ChooseSources(int target, const ViewGraph& graph, const std::vector<std::vector<int>>& appearance,
                               const std::vector<bool>& allowed, const NetworkPosesOptions& options);

// The depth range of method network's output, from the percentiles of the network's predicted
// target depths (one p02 / p98 per target, in the network's units) brought into the output frame
// by `scale`, widened as DepthRangeFromPoints widens triangulated depths, and never narrower than
// options.near / far (the network's near end can sit behind the nearest objects). A depth the network has
// collapsed (nearly constant: median p98 < 1.5 x median p02, or pinned to a bound of the range
// options.near / far it was run with) says nothing of the content: then options.near / far, the
// range typical of the scenes it was trained on. Returns whether the network's own range was used.
bool NetworkDepthRange(const std::vector<double>& p02, const std::vector<double>& p98, double scale,
                       const NetworkPosesOptions& options, double* near, double* far);

struct NetworkRelativePose {
  int target = 0, source = 0;
  Rigid3d src_from_tgt;  // the network's last prediction, in the depth range's units
};
struct NetworkTargetRun {
  std::vector<NetworkRelativePose> poses;
  double depth_p02 = 0, depth_p98 = 0;  // percentiles of the predicted target depth
  torch::Tensor inv_depth;              // [1, 1, H, W] float32: the last predicted target inverse depth
};
// One forward pass, target `target` with `sources`, from the identity (pose_init "network") or
// from initial_src_from_tgt (one per source: the network refines them). images: [V, 3, H, W]
// float32; intrinsics: [V, 3, 3] float32 (the target's are used for all, as in training). The
// depth range must be set on the network (SetDepthRange).
NetworkTargetRun RunPoseNetwork(PoseDepthNet& net, const torch::Tensor& images, const torch::Tensor& intrinsics,
                                int target, const std::vector<int>& sources,
                                const std::vector<Rigid3d>& initial_src_from_tgt = {});

// The network's relative poses (each an edge target -> source) averaged into cameras, with each
// image's confidence (network method, see the top of this file; graph: the view graph, possibly
// without edges).
struct NetworkEdgeAverage {
  RelativePoseAveragingResult averaged;
  std::vector<ImagePoseConfidence> confidence;  // per image
  double scale = 1;                             // output units per network unit: median over the kept edges
};
// graph_edge_weight > 0: the graph's essential-matrix edges are averaged too, at that weight each
// (NetworkPosesOptions::graph_edge_weight); the confidence still checks against them.
NetworkEdgeAverage AverageNetworkEdges(int num_images, const std::vector<NetworkRelativePose>& poses,
                                       const ViewGraph& graph, const RelativePoseAveragingOptions& options,
                                       double graph_edge_weight = 0);
// Per image, the confidence of the SfM's poses (see the top of this file): residuals over the
// edges the solution was made from (sfm.edge_used; all edges where it is empty) as the view graph
// holds them (self-calibrated, measured again with the refined intrinsics: RunGlobalSfm),
// edges_left_out, observations and their mean reprojection error. Unposed images keep the defaults.
std::vector<ImagePoseConfidence> SfmConfidence(const SfmResult& sfm, const std::vector<Camera>& cameras);

// The network method's per-image confidence of cameras (see the top of this file): against the view
// graph's edges where the image has any between posed images, else against the network's edges.
std::vector<ImagePoseConfidence> NetworkConfidence(const std::vector<Rigid3d>& cam_from_world,
                                                   const std::vector<bool>& posed,
                                                   const std::vector<NetworkRelativePose>& poses,
                                                   const ViewGraph& graph);

// A target registered against posed sources from the network's src_from_tgt per source.
struct NetworkRegistration {
  Rigid3d tgt_from_world;
  // SfM units per network unit: the median length ratio over the source pairs whose network
  // translation points within kScaleMaxDirectionErrorDeg of the SfM's, when the median pair does;
  // 1 otherwise (the network's depth range is set to the SfM's, so its units are the SfM's to begin
  // with).
  double scale = 1;
  int pairs = 0;  // source pairs (a, b) checked
  // Medians over pairs: network b_from_a (= b_from_tgt * a_from_tgt^-1) against the SfM's, the
  // rotation angle and the angle between translation directions (180 where a translation is zero).
  double pair_rotation_error_deg = 180;
  double pair_direction_error_deg = 180;
};
constexpr double kScaleMaxDirectionErrorDeg = 30.0;
// src_from_world: the sources' cameras; src_from_tgt: the network's poses, one per source (>= 1).
// The rotation is the mean of the per-source estimates R(src_from_tgt)^T R(src_from_world); the
// centre the per-coordinate median of the per-source centres world_from_src * (scale * t).
NetworkRegistration RegisterFromRelativePoses(const std::vector<Rigid3d>& src_from_world,
                                              const std::vector<Rigid3d>& src_from_tgt);

}  // namespace nerfreg
