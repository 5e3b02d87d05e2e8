// Commands of DBARF: dbarf poses (poses of unposed images) | dbarf eval-poses.
#include <cstdio>
#include <filesystem>
#include <map>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/pipeline/pose_image_folder.h"
#include "nerfreg/render/camera_plot.h"
#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;
namespace fs = std::filesystem;

namespace {

// The view graph's flags that name a choice, as given, until Apply parses them into the options.
struct ViewGraphChoices {
  explicit ViewGraphChoices(const ViewGraphOptions& o)
      : two_view(TwoViewEstimatorName(o.estimator)), normalization(SiftNormalizationName(o.normalization)) {}
  void Apply(ViewGraphOptions* o) const {
    o->pairs.strategy = ParsePairStrategy(pairs);
    o->estimator = ParseTwoViewEstimator(two_view);
    o->normalization = ParseSiftNormalization(normalization);
  }
  std::string pairs = "auto", two_view, normalization;
};

// The view graph's flags (features, pairs, two-view geometry) of dbarf poses.
void AddViewGraphOptions(CLI::App& app, ViewGraphOptions* o, ViewGraphChoices* choices) {
  app.add_option("--max-features", o->max_features, "SIFT keypoints per image (default 4000)");
  app.add_option("--min-inliers", o->min_inliers, "Fewest essential-matrix inliers of an edge (default 15)");
  app.add_option("--sift-contrast", o->contrast_threshold,
                 "SIFT contrast threshold of photo-sized images (default 0.01)");
  app.add_option("--sift-contrast-sparse", o->sparse_contrast_threshold,
                 "SIFT contrast threshold of enlarged (small) images and of those with fewer than "
                 "--sift-sparse-keypoints keypoints at --sift-contrast (default 0.005; 0: --sift-contrast everywhere)");
  app.add_option("--sift-sparse-keypoints", o->sparse_image_keypoints, "See --sift-contrast-sparse (default 300)");
  app.add_option("--sift-normalization", choices->normalization,
                 "SIFT descriptors matched as l1-root (RootSIFT, COLMAP's default) or l2 (OpenCV's) (default " +
                     choices->normalization + ")");
  app.add_option("--sift-upsample", o->upsample, "Enlarge images by this factor before SIFT (default 2)");
  app.add_option("--sift-upsample-max-side", o->upsample_max_side,
                 "... only while the enlarged image's longer side stays within this (default 1000; 0: always)");
  app.add_option("--ransac-px", o->ransac_threshold_px, "Two-view RANSAC threshold in pixels (default 1)");
  app.add_option("--two-view", choices->two_view,
                 "Two-view geometry estimator: usac (OpenCV's MAGSAC++) or ransac (OpenCV's RANSAC) (default " +
                     choices->two_view + ")");
  app.add_option("--pairs", choices->pairs,
                 "Pairs to match: exhaustive, sequential (name order, --overlap), retrieval (a vocabulary of the "
                 "images' own features) or auto (exhaustive up to 50 images, else retrieval, plus sequential for "
                 "numbered frames) (default auto)");
  app.add_option("--overlap", o->pairs.overlap, "Sequential pairs: the next N images in name order (default 10)");
}

}  // namespace

int RunDbarfPoses(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Estimate every image's camera from a folder of unposed images, with known intrinsics or "
                  "self-calibrated. --method classical: SIFT view graph, robust rotation averaging, global "
                  "positioning of cameras and points, triangulation and bundle adjustment (the classical "
                  "initialisation of DBARF). --method network: the DBARF pose network "
                  "predicts each image's neighbours relative to it (from the identity), and the relative poses are "
                  "averaged into global cameras (no SfM). --method auto (default): classical, and the images it "
                  "cannot pose are posed by the network against their posed neighbours. Writes OUT/transforms.json "
                  "(camera 0 at the identity, mean distance of the others to it 1; per frame \"posed_by\" (sfm or "
                  "network) and \"confidence\" (see its \"confidence_doc\"); images that could not be posed under "
                  "\"not_posed\" with the reason, low-confidence ones under \"low_confidence\"), a COLMAP model in "
                  "OUT/sparse/0 and "
                  "OUT/cameras.png (the posed cameras seen from above: centres and viewing directions, with a scale "
                  "bar whose length is logged).",
                  "nerfreg dbarf poses data/scene/images --intrinsics data/scene/transforms.json --out runs/poses");
  ImageFolderPosesOptions job;
  ImagePosesOptions& options = job.poses;
  // The network here starts from the identity: the weights trained for that (models/dbarf_pose_cpu.md).
  options.weights = DefaultDbarfPoseWeights();
  app.add_option("images", job.images_dir, "Folder of PNG / JPEG images (sorted by name)")->required();
  auto* t_opt = app.add_option("--intrinsics", job.intrinsics,
                               "transforms.json with fl_x fl_y cx cy w h or camera_angle_x (poses ignored); without "
                               "it or --focal the images are self-calibrated (EXIF prior, focal and k1, k2 refined)");
  auto* f_opt = app.add_option("--focal", job.focal, "Focal length in pixels (principal point at the image centre)");
  t_opt->excludes(f_opt);
  app.add_flag("--refine-intrinsics", job.refine_intrinsics,
               "Treat --intrinsics / --focal as priors: refine the focal length and k1, k2 in the bundle adjustment");
  app.add_option("--out", job.out, "Output folder")->required();
  app.add_option("--method", options.method, "classical, network or auto (default auto)");
  app.add_option(
      "--weights", options.weights,
      "DBARF weights for the network (default: models/dbarf_pose_cpu.pt, trained to pose from the identity)");
  app.add_option("--sources", options.network.num_sources, "Network: neighbours per target image (default 5)");
  app.add_option("--neighbours", job.neighbours,
                 "Network method: graph (SIFT view-graph neighbours, appearance where an image has too few) or "
                 "appearance (thumbnail similarity only, no SIFT) (default graph)");
  app.add_option("--near", options.network.near,
                 "Network method: nearest depth the network predicts, in units of the mean camera distance to the "
                 "first camera (default 7)");
  app.add_option("--far", options.network.far,
                 "Network method: farthest depth the network predicts, same units (default 40)");
  app.add_option("--graph-edge-weight", options.network.graph_edge_weight,
                 "Network method: weight of the essential-matrix edges averaged with the network's (default 0: none; "
                 "auto uses 10 where the SfM poses too few)");
  app.add_option("--refine-passes", options.network.refine_passes,
                 "Network method: passes after the first, each starting from the last cameras (default 0)");
  app.add_option("--bundle-adjust", options.network.bundle_adjust,
                 "Network method: 1 refines the averaged cameras by photometric bundle adjustment with the network's "
                 "depths, 0 not");
  app.add_option("--auto-doubt", options.auto_doubt_fraction,
                 "Auto: share of low-confidence SfM images at which the network poses all images too and the "
                 "photometrically better cameras are kept (default 0.25; 1: off)");
  app.add_option("--low-confidence-deg", options.low_confidence_deg,
                 "Warn about images whose pairwise rotations disagree with their pose by more than this (default 5)");
  app.add_flag("--no-keypoint-refinement{false}", options.sfm.refine_keypoints,
               "Keep SIFT's keypoint positions (default: each track's keypoints aligned with one another on the "
               "images by an affine warp of their windows before the solve)");
  ViewGraphChoices choices(options.sfm.view_graph);
  AddViewGraphOptions(app, &options.sfm.view_graph, &choices);
  unsigned int seed = 0;
  app.add_option("--seed", seed,
                 "Random seed of the two-view estimates (USAC) and of global positioning's start (default 0); other "
                 "seeds show how much the poses owe to the random draws");
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  choices.Apply(&options.sfm.view_graph);
  options.sfm.view_graph.seed = seed;
  options.sfm.global_positioning.seed += seed;
  options.device = ParseDevice(device);
  job.force = common.force;
  PoseImageFolder(job);
  return 0;
}

int RunDbarfEvalPoses(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Rotation and camera-centre errors of estimated cameras against ground truth, after a Sim(3) "
      "alignment: Umeyama on the centres (--align centers, as DBARF evaluates) or the rotations then the "
      "centres (--align rotations, also defined for collinear or 2-3 cameras). Frames are matched by image "
      "name; ground-truth frames missing from the estimate count as not posed. With --png, a picture of the "
      "aligned estimated cameras (red) against the ground truth (blue) seen from above, grey lines "
      "joining matching cameras, with a scale bar in ground-truth units (its length is logged).",
      "nerfreg dbarf eval-poses runs/poses/transforms.json --ground-truth data/scene/transforms.json "
      "--png runs/poses/eval_cameras.png");
  std::string estimate_path, gt_path, align = "centers", png;
  app.add_option("estimate", estimate_path, "Estimated transforms.json (e.g. from dbarf poses)")->required();
  app.add_option("--ground-truth", gt_path, "Ground-truth transforms.json")->required();
  app.add_option("--align", align, "centers or rotations")->check(CLI::IsMember({"centers", "rotations"}));
  app.add_option("--png", png, "Also write the aligned cameras against the ground truth, seen from above, to this PNG");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const Json est_json = ReadJsonFile(estimate_path), gt_json = ReadJsonFile(gt_path);
  // Sizes are in both files' intrinsics; images are not needed.
  const Dataset est = DatasetFromTransformsJson(est_json, estimate_path, ParentDir(estimate_path));
  const Dataset gt = DatasetFromTransformsJson(gt_json, gt_path, ParentDir(gt_path));
  std::map<std::string, Rigid3d> by_name;
  for (const Frame& f : est.frames) by_name[f.name] = f.cam_from_world;
  std::vector<Rigid3d> e, g;
  std::vector<std::string> missing;
  for (const Frame& f : gt.frames) {
    auto it = by_name.find(f.name);
    if (it == by_name.end()) {
      missing.push_back(f.name);
      continue;
    }
    e.push_back(it->second);
    g.push_back(f.cam_from_world);
  }
  const PoseEvaluation r =
      EvaluatePoses(e, g, align == "centers" ? PoseAlignment::kCenters : PoseAlignment::kRotationsAndCenters);
  if (!r.aligned)
    ThrowInputError(estimate_path, "frames",
                    "at least 3 cameras (not collinear for --align centers) matching the ground truth by name");
  if (!png.empty()) {
    // The estimate moved into the ground truth's frame by the alignment the errors were measured after.
    std::vector<Rigid3d> aligned;
    for (const Rigid3d& cam_from_est : e) aligned.push_back(r.gt_from_estimate.TransformCamera(cam_from_est));
    const CameraPlot plot = PlotCamerasFromAbove({{aligned, kEstimateColor}, {g, kGroundTruthColor}}, true);
    WriteImage(png, plot.image);
    LOG_INFO("{}: aligned estimate (red) against ground truth (blue) from above, scale bar {:g} units", png,
             plot.scale_bar_length);
  }
  const double base = r.widest_baseline > 0 ? 100.0 / r.widest_baseline : 0;
  const Json result = {{"images", gt.frames.size()},
                       {"posed", e.size()},
                       {"not_posed", missing},
                       {"align", align},
                       {"rotation_deg_mean", r.mean_rotation_deg},
                       {"rotation_deg_median", r.median_rotation_deg},
                       {"center_mean", r.mean_center},
                       {"center_median", r.median_center},
                       {"center_percent_mean", r.mean_center * base},
                       {"center_percent_median", r.median_center_percent},
                       {"widest_baseline", r.widest_baseline}};
  if (common.json) {
    std::printf("%s\n", result.dump().c_str());
  } else {
    std::printf("posed            %zu / %zu\n", e.size(), gt.frames.size());
    std::printf("rotation (deg)   mean %.4f  median %.4f\n", r.mean_rotation_deg, r.median_rotation_deg);
    std::printf("centre           mean %.5f  median %.5f  (%.3f %% / %.3f %% of the widest baseline %.4f)\n",
                r.mean_center, r.median_center, r.mean_center * base, r.median_center_percent, r.widest_baseline);
    for (const auto& name : missing) std::printf("not posed        %s\n", name.c_str());
  }
  return 0;
}
