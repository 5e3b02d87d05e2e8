#include "nerfreg/pipeline/pose_image_folder.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "nerfreg/data/colmap.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/dbarf_sfm/scene_cameras.h"
#include "nerfreg/dbarf_data/posed_images.h"
#include "nerfreg/render/camera_plot.h"
#include "nerfreg/sfm/global_sfm.h"
#include "nerfreg/sfm/sfm_quality.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/exif.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/memory.h"
#include "nerfreg/util/stage_times.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace fs = std::filesystem;

namespace {

// With EXIF focal lengths, the standard deviation (of the focal) beyond which the photos count as
// leaving the focal free even where the two starts agree: far beyond an EXIF focal's error, so
// below it the photos' own answer is kept (spider24's 1.0 % refined a prior 4 % off to within 1 %).
constexpr double kHoldExifFocalAboveRelativeStddev = 0.05;

// PNG / JPEG / PGM / PPM files of a folder, sorted by name.
std::vector<std::string> ListImages(const std::string& dir) {
  if (!DirExists(dir)) ThrowInputError(dir, "", "a folder of images");
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = LowerExtension(entry.path().string());
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".ppm")
      names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

// Intrinsics of each image from a transforms.json (top-level or per-frame `fl_x fl_y cx cy w h`
// or `camera_angle_x`); its poses are ignored. Frames are matched to images by name; images
// without a frame take the top-level intrinsics. The data-layer reader does the parsing. Each
// image's split ("train" where the file names none) goes to `splits` (one per name): the output
// keeps it, so `dbarf finetune` holds the file's test views out and `dbarf eval` renders them as
// novel views.
std::vector<Camera> CamerasFromTransforms(const std::string& path, const std::string& images_dir,
                                          const std::vector<std::string>& names, std::vector<std::string>* splits) {
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
  for (size_t k = 0; k < d.frames.size(); ++k) cameras.push_back(d.frames[k].camera), (*splits)[k] = d.frames[k].split;
  return cameras;
}

// Cameras of photos without a calibration file: a focal prior per image from its EXIF (or its size,
// util/exif.h), principal point at the centre, no distortion; `group` gets one camera group per
// make / model / size, whose intrinsics the SfM estimates and refines together. size_guess: whether
// every prior came from the image size (no EXIF focal length at all); all_exif: whether every one
// came from EXIF.
std::vector<Camera> PriorCameras(const std::vector<std::string>& names, const std::vector<PackedImage>& images,
                                 const std::vector<ExifInfo>& exif, const std::string& dir, std::vector<int>* group,
                                 bool* size_guess, bool* all_exif) {
  std::vector<Camera> cameras;
  std::map<std::string, int> group_of;
  group->clear();
  *size_guess = true;
  *all_exif = true;
  for (size_t k = 0; k < names.size(); ++k) {
    const PackedImage& im = images[k];
    const FocalPrior prior = FocalPriorFromExif(exif[k], im.width, im.height, JoinPaths(dir, names[k]));
    if (prior.source != "image-size") *size_guess = false;
    if (prior.source == "image-size") *all_exif = false;
    const std::string maker = exif[k].make + (exif[k].model.empty() ? "" : " " + exif[k].model);
    const std::string key =
        (maker.empty() ? "unknown camera" : maker) + " " + std::to_string(im.width) + "x" + std::to_string(im.height);
    const auto [it, inserted] = group_of.emplace(key, static_cast<int>(group_of.size()));
    group->push_back(it->second);
    cameras.push_back(
        Camera::Pinhole(im.width, im.height, prior.focal_px, prior.focal_px, 0.5 * im.width, 0.5 * im.height));
    if (inserted)
      LOG_INFO("{}: camera group {} ({}), focal prior {:.1f} px from {}", names[k], it->second, key, prior.focal_px,
               prior.source);
  }
  return cameras;
}

ColmapModel ModelFromSfm(const SfmResult& r, const std::vector<Camera>& cameras, const std::vector<std::string>& names,
                         const std::vector<PackedImage>& images) {
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
    if (!model.cameras.count(camera_id[k]))
      model.cameras[camera_id[k]] = ColmapCamera::FromCamera(camera_id[k], cameras[k]);
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
      const PackedImage& img = images[e.image];
      const int x = std::clamp(static_cast<int>(uv.x()), 0, img.width - 1),
                y = std::clamp(static_cast<int>(uv.y()), 0, img.height - 1);
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

// Whether a refined focal's standard deviation is within max_relative of it.
bool FocalDetermined(double focal_px, double stddev_px, double max_relative) {
  return std::isfinite(stddev_px) && stddev_px <= max_relative * focal_px;
}

// One camera group's refined intrinsics, as the log and transforms.json report them.
struct GroupCalibration {
  size_t first_image = 0;  // index into the images: the group's first
  double prior_focal_px = 0, focal_px = 0;
  double focal_stddev_px = 0;  // 0 when the adjustment did not state it
  bool stddev_known = false;
  bool determined = false;
  bool held = false;  // the focal is the (EXIF) prior, held: the photos left it free
  double k1 = 0, k2 = 0;
};

std::vector<GroupCalibration> CalibrationByGroup(const std::vector<int>& camera_group, const std::vector<Camera>& prior,
                                                 const ImagePosesResult& result, double max_relative_stddev) {
  std::vector<GroupCalibration> groups;
  std::set<int> seen;
  const std::vector<double>& sds = result.sfm.focal_stddev_px;
  for (size_t k = 0; k < result.cameras.size(); ++k) {
    if (!seen.insert(camera_group.empty() ? 0 : camera_group[k]).second) continue;
    GroupCalibration g;
    const Camera& c = result.cameras[k];
    g.first_image = k;
    g.prior_focal_px = prior[k].fx;
    g.focal_px = c.fx;
    g.stddev_known = k < sds.size();
    g.focal_stddev_px = g.stddev_known ? sds[k] : 0.0;
    g.held = result.sfm.focal_prior_held;
    g.determined = !g.held && g.stddev_known && FocalDetermined(c.fx, g.focal_stddev_px, max_relative_stddev);
    g.k1 = c.k1;
    g.k2 = c.k2;
    groups.push_back(g);
  }
  return groups;
}

// The posed images of OUT/transforms.json: posed frames (paths relative to OUT, so the file stays
// usable as a dataset), how each was posed, the view graph and the run's figures.
PosedImages MakePosedImages(const ImageFolderPosesOptions& o, const std::vector<std::string>& names,
                            const std::vector<Camera>& cameras, const std::vector<std::string>& splits,
                            const ImagePosesResult& result, const std::vector<GroupCalibration>& calibration,
                            const SfmQuality& quality, bool any_sfm, double seconds) {
  const SfmResult& r = result.sfm;
  PosedImages posed;
  posed.dataset.root = o.out;
  const fs::path out_abs = fs::absolute(o.out);
  int num_posed = 0, num_by_network = 0;
  for (size_t k = 0; k < names.size(); ++k) {
    num_posed += result.posed[k], num_by_network += result.posed_by[k] == "network";
    if (!result.posed[k]) continue;
    Frame f;
    f.name = names[k];
    f.file_path = fs::relative(fs::absolute(JoinPaths(o.images_dir, names[k])), out_abs).generic_string();
    f.camera = cameras[k];
    f.split = splits[k];
    f.cam_from_world = result.cam_from_world[k];
    posed.dataset.frames.push_back(std::move(f));
    posed.posed_by.push_back(result.posed_by[k]);
    posed.confidence.push_back(result.confidence[k]);
  }
  posed.not_posed = result.not_posed;
  for (size_t k = 0; k < names.size(); ++k)
    if (!result.posed[k]) posed.not_posed_reason.push_back(result.not_posed_reason[k]);
  posed.low_confidence = result.low_confidence;
  // The view graph, plus the pairs the network was run on that it lacks (0 inliers, so they rank
  // last): dbarf finetune / render take their neighbours from it, and images the matcher could
  // not relate have none otherwise.
  posed.view_graph = ViewGraphToJson(r.view_graph);
  std::set<std::pair<int, int>> added;
  for (const auto& [t, s] : result.network_pairs)
    if (!r.view_graph.FindEdge(t, s) && added.insert({std::min(t, s), std::max(t, s)}).second) {
      posed.view_graph.push_back({names[t], names[s], 0});
    }
  // The depth range and view graph go into the output too: dbarf finetune / render read them.
  posed.info = {{"images", names.size()},
                {"posed", num_posed},
                {"posed_by_network", num_by_network},
                {"method", o.poses.method},
                {"method_used", result.method_used},
                {"sift_normalization", SiftNormalizationName(result.sift_normalization)},
                {"points", r.points.size()},
                {"mean_reprojection_error_px", r.mean_reprojection_error_px},
                {"edges", r.view_graph.edges.size()},
                {"edges_used", r.num_edges_used},
                {"network_edges", result.num_network_edges},
                {"seconds_view_graph", r.seconds_view_graph},
                {"seconds_sfm", r.seconds_sfm},
                {"seconds_network", result.seconds_network},
                {"seconds", seconds},
                {"near", result.near},
                {"far", result.far},
                {"frame", "first posed camera at the identity; mean distance of the others to it = 1"},
                {"intrinsics", o.intrinsics.empty() && !(o.focal > 0) ? "self-calibrated"
                               : o.refine_intrinsics                  ? "refined from the given ones"
                                                                      : "given"},
                {"well_constrained", quality.WellConstrained()},
                {"problems", quality.problems}};
  if (!r.focal_stddev_px.empty()) {
    // One entry per camera group: the refined focal and how well the data determine it.
    nlohmann::json groups = nlohmann::json::array();
    for (const GroupCalibration& g : calibration) {
      if (!g.stddev_known) continue;
      const double sd = g.focal_stddev_px;
      groups.push_back({{"first_image", names[g.first_image]},
                        {"focal_px", g.focal_px},
                        {"focal_stddev_px", std::isfinite(sd) ? nlohmann::json(sd) : nlohmann::json(nullptr)},
                        {"determined", g.determined},
                        {"held_at_prior", g.held}});
    }
    posed.info["self_calibration"] = groups;
  }
  if (!result.auto_choice.empty()) {
    posed.info["auto_check"] = {{"kept", result.auto_choice},
                                {"sfm_photometric_error", result.auto_sfm_score},
                                {"network_photometric_error", result.auto_network_score}};
  }
  if (any_sfm) {
    posed.info["quality"] = {{"min_image_side_px", quality.min_image_side_px},
                             {"min_points_per_image", quality.min_points_per_image},
                             {"min_multiview_points_per_image", quality.min_multiview_points_per_image},
                             {"median_points_per_image", quality.median_points_per_image},
                             {"median_track_length", quality.median_track_length},
                             {"median_triangulation_angle_deg", quality.median_triangulation_angle_deg}};
  }
  if (o.poses.method != "classical") posed.info["weights"] = o.poses.weights;
  return posed;
}

}  // namespace

void ImageFolderPosesOptions::Check() const {
  if (focal < 0 || !std::isfinite(focal)) ThrowInputError("--focal", "", "a focal length in pixels > 0");
  if (!(max_focal_relative_stddev >= 0))
    throw std::invalid_argument("ImageFolderPosesOptions: max_focal_relative_stddev >= 0");
  if (neighbours != "graph" && neighbours != "appearance") {
    throw InputError("--neighbours: expected graph or appearance, got \"" + neighbours + "\"");
  }
  poses.Check();
  if (poses.method != "classical" && !FileExists(poses.weights))
    ThrowInputError(poses.weights, "", "a DBARF weights file (--weights)");
}

ImageFolderPosesResult PoseImageFolder(ImageFolderPosesOptions o) {
  o.Check();
  o.poses.network.match_images = o.neighbours == "graph";
  std::string& out = o.out;
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  CheckCanWriteOutput(out, o.force, {o.images_dir, o.intrinsics});
  const Timer timer;

  const std::vector<std::string> names = ListImages(o.images_dir);
  if (names.size() < 3)
    ThrowInputError(o.images_dir, "",
                    "at least 3 PNG / JPEG / PGM / PPM images, found " + std::to_string(names.size()));
  // Held as the files' integers for the whole run (a quarter of float's memory for 8-bit files),
  // each decoded to float once on the way.
  std::vector<PackedImage> images;
  std::vector<ExifInfo> exif;
  for (const auto& name : names) {
    ImageFileFacts facts;
    const Image im = ReadImage(JoinPaths(o.images_dir, name), ImageReadOptions(), &facts);
    images.push_back(PackImage(im, facts.bits_per_channel == 16 ? 16 : 8));
    exif.push_back(facts.exif);
  }
  std::vector<Camera> cameras;
  std::vector<std::string> splits(names.size(), "train");  // --intrinsics' splits, if given
  const bool calibrated = !o.intrinsics.empty() || o.focal > 0;
  if (!o.intrinsics.empty()) {
    cameras = CamerasFromTransforms(o.intrinsics, o.images_dir, names, &splits);
  } else if (o.focal > 0) {
    for (const PackedImage& im : images)
      cameras.push_back(Camera::Pinhole(im.width, im.height, o.focal, o.focal, 0.5 * im.width, 0.5 * im.height));
  } else {
    bool size_guess = false, all_exif = false;
    cameras = PriorCameras(names, images, exif, o.images_dir, &o.poses.camera_group, &size_guess, &all_exif);
    // A focal length guessed from the image size can start the solve in a wrong minimum: solved
    // again from 1.4x it (SfmOptions::focal_starts).
    if (size_guess) o.poses.sfm.focal_starts = {1.0, 1.4};
    // Every photo's focal from EXIF: solved from it and from 1.2x it; where the photos leave the
    // focal free (the two end apart with as much support), EXIF's focal is held rather than the
    // start choosing one (SfmOptions::hold_focal_prior_above).
    if (all_exif) {
      o.poses.sfm.focal_starts = {1.0, 1.2};
      o.poses.sfm.focal_start_below = 0;
      o.poses.sfm.hold_focal_prior_above = kHoldExifFocalAboveRelativeStddev;
    }
  }
  if (!calibrated || o.refine_intrinsics) {
    o.poses.sfm.view_graph.estimate_focal = !calibrated;
    o.poses.sfm.refine_focal = true;
    o.poses.sfm.refine_distortion = true;
  }
  StageTimes times;
  times.Record("read images", timer.Seconds());
  LOG_INFO("posing {} images of {} (method {})", names.size(), o.images_dir, o.poses.method);
  const ImagePosesResult result = EstimateImagePoses(images, cameras, names, o.poses, o.images_dir);
  times.Append(result.times);
  const std::vector<GroupCalibration> calibration =
      CalibrationByGroup(o.poses.camera_group, cameras, result, o.max_focal_relative_stddev);
  if (!calibrated || o.refine_intrinsics) {
    for (const GroupCalibration& g : calibration) {
      const std::string& name = names[g.first_image];
      if (g.held) {
        LOG_WARN(
            "{} and its camera group: the photos leave the focal length free (refined it would be uncertain by "
            "+- {:.1f} px, {:.1f} %): EXIF's {:.1f} px is kept, held; k1 {:.4f}, k2 {:.4f}",
            name, g.focal_stddev_px, 100.0 * g.focal_stddev_px / g.focal_px, g.focal_px, g.k1, g.k2);
        continue;
      }
      LOG_INFO("{} and its camera group: focal {:.1f} +- {:.1f} px (prior {:.1f}), k1 {:.4f}, k2 {:.4f}", name,
               g.focal_px, g.focal_stddev_px, g.prior_focal_px, g.k1, g.k2);
      if (g.stddev_known && !g.determined) {
        LOG_WARN(
            "{} and its camera group: the photos leave the focal length poorly determined ({:.1f} +- {:.1f} px, "
            "{:.1f} %; the poses hold only as well as it): too few views or points, or a camera motion close to "
            "a critical one (pure translation, centres on a line, optical axes through one point); give --focal "
            "or --intrinsics, or photos with EXIF",
            name, g.focal_px, g.focal_stddev_px, 100.0 * g.focal_stddev_px / g.focal_px);
      }
    }
  }
  cameras = result.cameras;
  const Timer writing;
  const SfmResult& r = result.sfm;  // final cameras, with the SfM's points (if any)
  ImageFolderPosesResult summary;
  summary.images = static_cast<int>(names.size());
  for (size_t k = 0; k < names.size(); ++k)
    summary.posed += result.posed[k], summary.posed_by_network += result.posed_by[k] == "network";
  if (summary.posed == 0)
    ThrowInputError(o.images_dir, "", "images that share enough features to be posed (no two do)");
  // A low reprojection error is no proof: a solution the data cannot pin down is reported as such.
  // Judged on the images the SfM posed (the network's have their own confidence below).
  SfmResult sfm_part = r;
  for (size_t k = 0; k < sfm_part.posed.size() && k < result.posed_by.size(); ++k)
    sfm_part.posed[k] = result.posed_by[k] == "sfm";
  const bool any_sfm = std::count(result.posed_by.begin(), result.posed_by.end(), "sfm") > 0;
  SfmQuality quality = any_sfm ? AssessSfm(sfm_part, cameras) : SfmQuality{};
  if (!any_sfm) {
    // The pixels' own limit holds whatever posed them: images too small to pin cameras down by
    // matching are too small for the network too (auto may keep its cameras on them).
    int side = std::numeric_limits<int>::max();
    for (const Camera& c : cameras) side = std::min({side, c.width, c.height});
    if (const std::string small = SmallImagesProblem(side); !small.empty()) {
      quality.problems.push_back(small + ": too few pixels to pin the cameras down");
    }
  }
  for (const auto& problem : quality.problems) {
    LOG_WARN("{}: the poses are not well constrained: {}; do not trust them", o.images_dir, problem);
  }

  // Everything goes into a temporary folder moved into place at the end.
  OutputDir output(out, o.force, {o.images_dir, o.intrinsics});
  const std::string& tmp = output.tmp();
  CreateDirectories(JoinPaths(tmp, "sparse/0"));
  {
    PosedImages posed =
        MakePosedImages(o, names, cameras, splits, result, calibration, quality, any_sfm, timer.Seconds());
    WriteColmapBinary(ModelFromSfm(r, cameras, names, images), JoinPaths(tmp, "sparse/0"));
    std::vector<Rigid3d> cams;
    for (const Frame& f : posed.dataset.frames) cams.push_back(f.cam_from_world);
    const CameraPlot plot = PlotCamerasFromAbove({{cams, kEstimateColor}}, false);
    WriteImage(JoinPaths(tmp, "cameras.png"), plot.image);
    LOG_INFO("{}/cameras.png: posed cameras seen from above, scale bar {:g} units", out, plot.scale_bar_length);
    // transforms.json last, so its stage times cover the other outputs' writing.
    times.Record("write output", writing.Seconds());
    posed.info["timings_s"] = times.ToJson();
    posed.info["timings_s"]["total"] = timer.Seconds();
    posed.info["peak_memory_mb"] = PeakResidentMegabytes();
    WritePosedImages(JoinPaths(tmp, "transforms.json"), posed);
    output.Commit();
  }
  for (size_t k = 0; k < names.size(); ++k)
    if (!result.posed[k])
      LOG_WARN("{}: not posed ({}); listed under \"not_posed\" in {}/transforms.json", names[k],
               result.not_posed_reason[k], out);
  if (!result.low_confidence.empty()) {
    LOG_WARN("low-confidence poses ({}): {}; see \"confidence\" in {}/transforms.json", result.low_confidence.size(),
             DescribeLowConfidence(result, names), out);
  }
  summary.well_constrained = quality.WellConstrained();
  summary.seconds = timer.Seconds();
  LOG_INFO("stages (s): {}; total {:.2f}; peak memory {:.0f} MB", times.Summary(), timer.Seconds(),
           PeakResidentMegabytes());
  LOG_INFO("posed {}/{} images ({} by the network){}, {} points, mean reprojection error {:.3f} px, in {:.2f} s -> {}",
           summary.posed, names.size(), summary.posed_by_network,
           summary.well_constrained ? "" : " (NOT well constrained: see the warnings)", r.points.size(),
           r.mean_reprojection_error_px, timer.Seconds(), out);
  return summary;
}

}  // namespace nerfreg
