// Commands of DBARF: dbarf poses (poses of unposed images) | dbarf eval-poses.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <unistd.h>

#include "nerfreg/data/colmap.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/dbarf/dbarf_scene.h"
#include "nerfreg/dbarf/network_poses.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/render/camera_plot.h"
#include "nerfreg/sfm/global_sfm.h"
#include "nerfreg/sfm/sfm_quality.h"
#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/util/stage_times.h"

using namespace nerfreg;
namespace fs = std::filesystem;

namespace {

// PNG / JPEG files of a folder, sorted by name.
std::vector<std::string> ListImages(const std::string& dir) {
  if (!DirExists(dir)) ThrowInputError(dir, "", "a folder of images");
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = LowerExtension(entry.path().string());
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

// Intrinsics of each image from a transforms.json (top-level or per-frame `fl_x fl_y cx cy w h`
// or `camera_angle_x`); its poses are ignored. Frames are matched to images by name; images
// without a frame take the top-level intrinsics. The data-layer reader does the parsing.
std::vector<Camera> CamerasFromTransforms(const std::string& path, const std::string& images_dir,
                                          const std::vector<std::string>& names) {
  Json json = ReadJsonFile(path);
  if (!json.is_object()) ThrowInputError(path, "", "a JSON object with intrinsics");
  std::map<std::string, Json> by_name;
  if (json.contains("frames") && json["frames"].is_array()) {
    for (const Json& f : json["frames"])
      if (f.is_object() && f.contains("file_path") && f["file_path"].is_string()) {
        std::string p = f["file_path"].get<std::string>();
        if (fs::path(p).extension().empty()) p += ".png";
        by_name[fs::path(p).filename().string()] = f;
      }
  }
  Json frames = Json::array();
  const Json identity = MatrixToJson(Eigen::Matrix4d::Identity());
  for (const std::string& name : names) {
    auto it = by_name.find(name);
    Json f = it == by_name.end() ? Json::object() : it->second;
    f["file_path"] = name;
    f["transform_matrix"] = identity;  // poses in the file are not used
    frames.push_back(f);
  }
  json["frames"] = frames;
  const Dataset d = DatasetFromTransformsJson(json, path, images_dir);
  std::vector<Camera> cameras;
  for (const Frame& f : d.frames) cameras.push_back(f.camera);
  return cameras;
}

ColmapModel ModelFromSfm(const SfmResult& r, const std::vector<Camera>& cameras, const std::vector<std::string>& names,
                         const std::vector<Image>& images) {
  ColmapModel model;
  std::vector<std::uint32_t> camera_id(cameras.size());
  for (size_t k = 0; k < cameras.size(); ++k) {
    camera_id[k] = static_cast<std::uint32_t>(k + 1);
    for (size_t m = 0; m < k; ++m) {
      const Camera &a = cameras[k], &b = cameras[m];
      if (a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
          a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 && a.p2 == b.p2) {
        camera_id[k] = camera_id[m];
        break;
      }
    }
    if (!model.cameras.count(camera_id[k])) model.cameras[camera_id[k]] = ColmapCamera::FromCamera(camera_id[k], cameras[k]);
  }
  for (size_t k = 0; k < names.size(); ++k) {
    if (!r.posed[k]) continue;
    ColmapImage im;
    im.image_id = static_cast<std::uint32_t>(k + 1);
    im.cam_from_world = r.cam_from_world[k];
    im.camera_id = camera_id[k];
    im.name = names[k];
    for (const auto& uv : r.view_graph.keypoints[k]) im.points2d.push_back({uv.x(), uv.y(), -1});
    model.images[im.image_id] = std::move(im);
  }
  std::uint64_t id = 0;
  for (const SfmPoint& p : r.points) {
    ColmapPoint3D pt;
    pt.point3d_id = ++id;
    pt.xyz = p.x_in_world;
    double error = 0;
    Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
    for (const auto& e : p.elements) {
      const Eigen::Vector2d& uv = r.view_graph.keypoints[e.image][e.keypoint];
      error += ReprojectionErrorPx(cameras[e.image], r.cam_from_world[e.image], p.x_in_world, uv) / p.elements.size();
      const Image& img = images[e.image];
      const int x = std::clamp(static_cast<int>(uv.x()), 0, img.width - 1), y = std::clamp(static_cast<int>(uv.y()), 0, img.height - 1);
      for (int c = 0; c < 3; ++c) rgb(c) += img.at(x, y, std::min(c, img.channels - 1)) / p.elements.size();
      pt.track.push_back({static_cast<std::uint32_t>(e.image + 1), static_cast<std::uint32_t>(e.keypoint)});
      model.images[e.image + 1].points2d[e.keypoint].point3d_id = static_cast<std::int64_t>(pt.point3d_id);
    }
    for (int c = 0; c < 3; ++c) pt.rgb[c] = static_cast<std::uint8_t>(std::clamp(rgb(c), 0.0, 1.0) * 255 + 0.5);
    pt.error = error;
    model.points3d[pt.point3d_id] = std::move(pt);
  }
  return model;
}

}  // namespace

int RunDbarfPoses(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Estimate every image's camera from a folder of unposed images with known intrinsics. --method "
                  "classical: SIFT view graph, robust rotation and translation averaging, triangulation and bundle "
                  "adjustment (the classical initialisation of DBARF). --method network: the DBARF pose network "
                  "predicts each image's neighbours relative to it (from the identity), and the relative poses are "
                  "averaged into global cameras (no SfM). --method auto (default): classical, and the images it "
                  "cannot pose are posed by the network against their posed neighbours. Writes OUT/transforms.json "
                  "(camera 0 at the identity, mean distance of the others to it 1; per frame \"posed_by\" (sfm or "
                  "network) and \"confidence\" (see its \"confidence_doc\"); images that could not be posed under "
                  "\"not_posed\", low-confidence ones under \"low_confidence\"), a COLMAP model in OUT/sparse/0 and "
                  "OUT/cameras.png (the posed cameras seen from above: centres and viewing directions, with a scale "
                  "bar whose length is logged).",
                  "nerfreg dbarf poses data/scene/images --intrinsics data/scene/transforms.json --out runs/poses");
  std::string images_dir, intrinsics, out, neighbours = "graph";
  double focal = 0;
  ImagePosesOptions options;
  // The network here starts from the identity: the weights trained for that (models/dbarf_pose_cpu.md).
  options.weights = DefaultDbarfPoseWeights();
  app.add_option("images", images_dir, "Folder of PNG / JPEG images (sorted by name)")->required();
  auto* t_opt = app.add_option("--intrinsics", intrinsics, "transforms.json with fl_x fl_y cx cy w h or camera_angle_x (poses ignored)");
  auto* f_opt = app.add_option("--focal", focal, "Focal length in pixels (principal point at the image centre)");
  t_opt->excludes(f_opt);
  app.add_option("--out", out, "Output folder")->required();
  app.add_option("--method", options.method, "classical, network or auto (default auto)");
  app.add_option("--weights", options.weights, "DBARF weights for the network (default: models/dbarf_pose_cpu.pt, trained to pose from the identity)");
  app.add_option("--sources", options.network.num_sources, "Network: neighbours per target image (default 5)");
  app.add_option("--neighbours", neighbours,
                 "Network method: graph (SIFT view-graph neighbours, appearance where an image has too few) or "
                 "appearance (thumbnail similarity only, no SIFT) (default graph)");
  app.add_option("--near", options.network.near, "Network method: nearest depth the network predicts, in units of the mean camera distance to the first camera (default 7)");
  app.add_option("--far", options.network.far, "Network method: farthest depth the network predicts, same units (default 40)");
  app.add_option("--refine-passes", options.network.refine_passes,
                 "Network method: passes after the first, each starting from the last cameras (default 0)");
  app.add_option("--low-confidence-deg", options.low_confidence_deg,
                 "Warn about images whose pairwise rotations disagree with their pose by more than this (default 5)");
  app.add_option("--max-features", options.sfm.view_graph.max_features, "SIFT keypoints per image (default 4000)");
  app.add_option("--min-inliers", options.sfm.view_graph.min_inliers, "Fewest essential-matrix inliers of an edge (default 15)");
  app.add_option("--sift-contrast", options.sfm.view_graph.contrast_threshold, "SIFT contrast threshold (default 0.005)");
  app.add_option("--sift-upsample", options.sfm.view_graph.upsample, "Enlarge images by this factor before SIFT (default 2)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (intrinsics.empty() && !(focal > 0)) throw InputError("dbarf poses: give --intrinsics T.json or --focal PX (> 0)");
  if (neighbours != "graph" && neighbours != "appearance") {
    throw InputError("--neighbours: expected graph or appearance, got \"" + neighbours + "\"");
  }
  options.network.match_images = neighbours == "graph";
  options.Check();
  if (options.method != "classical" && !FileExists(options.weights)) ThrowInputError(options.weights, "", "a DBARF weights file (--weights)");
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  CheckCanWriteOutput(out, common.force, {images_dir, intrinsics});
  const Timer timer;

  const std::vector<std::string> names = ListImages(images_dir);
  if (names.size() < 3) ThrowInputError(images_dir, "", "at least 3 PNG / JPEG images, found " + std::to_string(names.size()));
  std::vector<Image> images;
  for (const auto& name : names) images.push_back(ReadImage(JoinPaths(images_dir, name)));
  std::vector<Camera> cameras;
  if (!intrinsics.empty()) {
    cameras = CamerasFromTransforms(intrinsics, images_dir, names);
  } else {
    for (const Image& im : images) cameras.push_back(Camera::Pinhole(im.width, im.height, focal, focal, 0.5 * im.width, 0.5 * im.height));
  }
  StageTimes times;
  times.Record("read images", timer.Seconds());
  LOG_INFO("posing {} images of {} (method {})", names.size(), images_dir, options.method);
  const ImagePosesResult result = EstimateImagePoses(images, cameras, names, options, images_dir);
  times.Append(result.times);
  const Timer writing;
  const SfmResult& r = result.sfm;  // final cameras, with the SfM's points (if any)
  int num_posed = 0, num_by_network = 0;
  for (size_t k = 0; k < names.size(); ++k) num_posed += result.posed[k], num_by_network += result.posed_by[k] == "network";
  if (num_posed == 0) ThrowInputError(images_dir, "", "images that share enough features to be posed (no two do)");
  // A low reprojection error is no proof: a solution the data cannot pin down is reported as such.
  // Judged on the images the SfM posed (the network's have their own confidence below).
  SfmResult sfm_part = r;
  for (size_t k = 0; k < sfm_part.posed.size() && k < result.posed_by.size(); ++k) sfm_part.posed[k] = result.posed_by[k] == "sfm";
  const bool any_sfm = std::count(result.posed_by.begin(), result.posed_by.end(), "sfm") > 0;
  const SfmQuality quality = any_sfm ? AssessSfm(sfm_part, cameras) : SfmQuality{};
  for (const auto& problem : quality.problems) {
    LOG_WARN("{}: the poses are not well constrained: {}; do not trust them", images_dir, problem);
  }

  // The depth range and view graph go into the output too: dbarf finetune / render read them.
  const double near = result.near, far = result.far;
  // Everything goes into a temporary folder moved into place at the end.
  OutputDir output(out, common.force, {images_dir, intrinsics});
  const std::string& tmp = output.tmp();
  CreateDirectories(JoinPaths(tmp, "sparse/0"));
  {
    Dataset dataset;
    dataset.root = out;
    const fs::path out_abs = fs::absolute(out);
    std::vector<int> posed_index;
    for (size_t k = 0; k < names.size(); ++k) {
      if (!result.posed[k]) continue;
      Frame f;
      f.name = names[k];
      // Relative to OUT, so the file stays usable as a dataset; the file name is the image's.
      f.file_path = fs::relative(fs::absolute(JoinPaths(images_dir, names[k])), out_abs).generic_string();
      f.camera = cameras[k];
      f.cam_from_world = result.cam_from_world[k];
      dataset.frames.push_back(std::move(f));
      posed_index.push_back(static_cast<int>(k));
    }
    Json json = TransformsJsonFromDataset(dataset);
    for (size_t m = 0; m < posed_index.size(); ++m) {
      const ImagePoseConfidence& c = result.confidence[posed_index[m]];
      Json conf = {{"edges", c.edges},
                   {"rotation_residual_deg", c.rotation_residual_deg},
                   {"direction_residual_deg", c.direction_residual_deg},
                   {"low", c.low}};
      if (c.observations >= 0) conf["observations"] = c.observations, conf["reprojection_error_px"] = c.reprojection_error_px;
      json["frames"][m]["posed_by"] = result.posed_by[posed_index[m]];
      json["frames"][m]["confidence"] = conf;
    }
    json["not_posed"] = result.not_posed;
    json["low_confidence"] = result.low_confidence;
    json["confidence_doc"] =
        "per frame: the median angles (deg) between the image's pairwise relative rotations / translation "
        "directions and those of the accepted poses, over `edges` of them. sfm: its view-graph (essential-matrix) "
        "edges to other SfM-posed images, plus its triangulated observations and their mean reprojection error. "
        "network, method network: its view-graph edges against the averaged cameras (its network edges where it has "
        "none). network, method auto: the network's relative "
        "pose between two of its SfM-posed sources (through the image) against the SfM's, per source pair. low: no "
        "edge, rotation residual above --low-confidence-deg, direction residual above 30 deg, or (sfm) fewer than "
        "10 observations.";
    // The view graph, plus the pairs the network was run on that it lacks (0 inliers, so they rank
    // last): dbarf finetune / render take their neighbours from it, and images the matcher could
    // not relate have none otherwise.
    json["view_graph"] = ViewGraphToJson(r.view_graph);
    std::set<std::pair<int, int>> added;
    for (const auto& [t, s] : result.network_pairs)
      if (!r.view_graph.FindEdge(t, s) && added.insert({std::min(t, s), std::max(t, s)}).second) {
        json["view_graph"].push_back({names[t], names[s], 0});
      }
    json["dbarf_poses"] = {{"images", names.size()},
                           {"posed", num_posed},
                           {"posed_by_network", num_by_network},
                           {"method", options.method},
                           {"method_used", result.method_used},
                           {"points", r.points.size()},
                           {"mean_reprojection_error_px", r.mean_reprojection_error_px},
                           {"edges", r.view_graph.edges.size()},
                           {"edges_used", r.num_edges_used},
                           {"network_edges", result.num_network_edges},
                           {"seconds_view_graph", r.seconds_view_graph},
                           {"seconds_sfm", r.seconds_sfm},
                           {"seconds_network", result.seconds_network},
                           {"seconds", timer.Seconds()},
                           {"near", near},
                           {"far", far},
                           {"frame", "first posed camera at the identity; mean distance of the others to it = 1"},
                           {"well_constrained", quality.WellConstrained()},
                           {"problems", quality.problems}};
    if (any_sfm) {
      json["dbarf_poses"]["quality"] = {{"min_image_side_px", quality.min_image_side_px},
                                        {"min_points_per_image", quality.min_points_per_image},
                                        {"median_points_per_image", quality.median_points_per_image},
                                        {"median_track_length", quality.median_track_length},
                                        {"median_triangulation_angle_deg", quality.median_triangulation_angle_deg}};
    }
    if (options.method != "classical") json["dbarf_poses"]["weights"] = options.weights;
    WriteColmapBinary(ModelFromSfm(r, cameras, names, images), JoinPaths(tmp, "sparse/0"));
    std::vector<Rigid3d> posed;
    for (const Frame& f : dataset.frames) posed.push_back(f.cam_from_world);
    const CameraPlot plot = PlotCamerasFromAbove({{posed, kEstimateColor}}, false);
    WriteImage(JoinPaths(tmp, "cameras.png"), plot.image);
    LOG_INFO("{}/cameras.png: posed cameras seen from above, scale bar {:g} units", out, plot.scale_bar_length);
    times.Record("write output", writing.Seconds());
    json["dbarf_poses"]["timings_s"] = times.ToJson();
    json["dbarf_poses"]["timings_s"]["total"] = timer.Seconds();
    WriteJsonFile(JoinPaths(tmp, "transforms.json"), json);
    output.Commit();
  }
  for (const auto& name : result.not_posed) LOG_WARN("{}: not posed; listed under \"not_posed\" in {}/transforms.json", name, out);
  if (!result.low_confidence.empty()) {
    std::string list;
    for (const auto& name : result.low_confidence) list += (list.empty() ? "" : ", ") + name;
    LOG_WARN("low-confidence poses ({}): {}; see \"confidence\" in {}/transforms.json", result.low_confidence.size(), list, out);
  }
  LOG_INFO("stages (s): {}; total {:.2f}", times.Summary(), timer.Seconds());
  LOG_INFO("posed {}/{} images ({} by the network){}, {} points, mean reprojection error {:.3f} px, in {:.2f} s -> {}",
           num_posed, names.size(), num_by_network, quality.WellConstrained() ? "" : " (NOT well constrained: see the warnings)",
           r.points.size(), r.mean_reprojection_error_px, timer.Seconds(), out);
  return 0;
}

int RunDbarfEvalPoses(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
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
  const PoseEvaluation r = EvaluatePoses(e, g, align == "centers" ? PoseAlignment::kCenters : PoseAlignment::kRotationsAndCenters);
  if (!r.aligned) ThrowInputError(estimate_path, "frames", "at least 3 cameras (not collinear for --align centers) matching the ground truth by name");
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
    std::printf("centre           mean %.5f  median %.5f  (%.3f %% / %.3f %% of the widest baseline %.4f)\n", r.mean_center,
                r.median_center, r.mean_center * base, r.median_center_percent, r.widest_baseline);
    for (const auto& name : missing) std::printf("not posed        %s\n", name.c_str());
  }
  return 0;
}
