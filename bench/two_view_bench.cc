// The view graph's two hot stages pair by pair (issue 44): descriptor matching and two-view
// geometry, on one thread, for every pair of a folder of images with known intrinsics and poses
// (a render's transforms.json; without "frames" in it, every image of the folder and no truth). Each two-view variant
// (estimator x early rejection) runs on the same putative matches; per variant: time per pair (all pairs, pairs that
// became edges, pairs that did not), edges found, and the edges' relative rotation and translation-direction errors
// against the truth. Prints a Markdown table and writes every figure to --json.
//   build/bench/nerfreg_two_view_bench --images /tmp/poses_scale/spider24/images \
//     --intrinsics /tmp/poses_scale/spider24/transforms.json --json /tmp/two_view.json
// Options: --contrast C (SIFT contrast threshold, default the SfM's 0.005), --max-features N
// (4000), --min-inliers N (15, the SfM's), --max-pairs N (every pair: 0). Times are thread CPU
// time, on one thread.
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {
namespace {

// This thread's CPU time in seconds: per-pair costs that other jobs on a shared machine do not
// inflate (the wall clock does).
double Now() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double Max(const std::vector<double>& v) { return v.empty() ? NAN : *std::max_element(v.begin(), v.end()); }

// An edge whose relative rotation is further than this from the truth is counted as wrong.
constexpr double kWrongEdgeDeg = 5;

struct Variant {
  std::string name;
  TwoViewEstimator estimator;
  bool early_rejection;
  bool refine_ransac = false;  // ViewGraphOptions::refine_ransac
};

int Run(int argc, char** argv) {
  std::string images_dir, intrinsics, json_out;
  ViewGraphOptions options;
  options.contrast_threshold = 0.005;  // as SfmViewGraphDefaults (sfm/global_sfm.cc)
  options.min_inliers = 15;
  options.upsample = 2;
  options.upsample_max_side = 1000;
  int max_pairs = 0;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a], v = argv[a + 1];
    if (k == "--images")
      images_dir = v;
    else if (k == "--intrinsics")
      intrinsics = v;
    else if (k == "--json")
      json_out = v;
    else if (k == "--contrast")
      options.contrast_threshold = std::stod(v);
    else if (k == "--max-features")
      options.max_features = std::stoi(v);
    else if (k == "--min-inliers")
      options.min_inliers = std::stoi(v);
    else if (k == "--max-pairs")
      max_pairs = std::stoi(v);
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  if (images_dir.empty() || intrinsics.empty()) {
    std::fprintf(stderr, "usage: %s --images DIR --intrinsics transforms.json [--json OUT] [options]\n", argv[0]);
    return 2;
  }
  cv::setNumThreads(1);  // per-pair costs on one core
  const Json t = ReadJsonFile(intrinsics);
  std::vector<std::string> names;
  std::vector<Rigid3d> cam_from_world;
  for (const auto& f : t["frames"]) {
    std::string path = f["file_path"].get<std::string>();
    std::string name = std::filesystem::path(path).filename().string();
    if (name.find('.') == std::string::npos) name += ".png";
    if (!std::filesystem::exists(images_dir + "/" + name)) name = std::filesystem::path(name).stem().string() + ".jpg";
    Eigen::Matrix4d c2w;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) c2w(r, c) = f["transform_matrix"][r][c].get<double>();
    c2w.col(1) *= -1;  // OpenGL camera axes -> OpenCV
    c2w.col(2) *= -1;
    names.push_back(name);
    cam_from_world.push_back(Rigid3d::FromMatrix(Eigen::Matrix4d(c2w.inverse())));
  }
  if (names.empty()) {  // intrinsics only: every image of the folder, no truth
    for (const auto& entry : std::filesystem::directory_iterator(images_dir)) names.push_back(entry.path().filename());
    std::sort(names.begin(), names.end());
  }
  const bool have_truth = !cam_from_world.empty();
  const int n = static_cast<int>(names.size());
  const int w = t["w"].get<int>(), h = t["h"].get<int>();
  Camera cam = Camera::Pinhole(w, h, t["fl_x"].get<double>(), t.value("fl_y", t["fl_x"].get<double>()),
                               t.value("cx", w / 2.0), t.value("cy", h / 2.0));
  cam.k1 = t.value("k1", 0.0);
  cam.k2 = t.value("k2", 0.0);
  cam.p1 = t.value("p1", 0.0);
  cam.p2 = t.value("p2", 0.0);
  const double focal = 0.5 * (cam.fx + cam.fy);

  std::vector<SiftFeatures> features(n);
  std::vector<std::vector<Eigen::Vector2d>> normalised(n);
  double seconds_features = 0;
  for (int k = 0; k < n; ++k) {
    const Image image = ReadImage(images_dir + "/" + names[k]);
    const double t0 = Now();
    features[k] = ExtractSiftFeatures(image, options);
    seconds_features += Now() - t0;
    for (const auto& uv : features[k].keypoints) normalised[k].push_back(cam.CamFromImg(uv).head<2>());
  }
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) pairs.push_back({i, j});
  if (max_pairs > 0 && static_cast<int>(pairs.size()) > max_pairs) {
    std::vector<std::pair<int, int>> every;
    for (int p = 0; p < max_pairs; ++p) every.push_back(pairs[static_cast<size_t>(p) * pairs.size() / max_pairs]);
    pairs = every;
  }
  const int num_pairs = static_cast<int>(pairs.size());
  std::vector<std::vector<std::pair<int, int>>> matches(num_pairs);
  double seconds_matching = 0;
  for (int p = 0; p < num_pairs; ++p) {
    const double t0 = Now();
    matches[p] =
        MatchDescriptors(features[pairs[p].first].descriptors, features[pairs[p].second].descriptors, options.ratio);
    seconds_matching += Now() - t0;
  }
  std::vector<double> keypoints, num_matches;
  for (const auto& f : features) keypoints.push_back(static_cast<double>(f.keypoints.size()));
  for (const auto& m : matches) num_matches.push_back(static_cast<double>(m.size()));

  Json out;
  out["images"] = images_dir;
  out["pairs"] = num_pairs;
  out["contrast_threshold"] = options.contrast_threshold;
  out["max_features"] = options.max_features;
  out["min_inliers"] = options.min_inliers;
  out["keypoints_median"] = Median(keypoints);
  out["matches_median"] = Median(num_matches);
  out["features_s_per_image"] = seconds_features / n;
  out["matching_ms_per_pair"] = 1000 * seconds_matching / num_pairs;
  std::printf("%d images, %d pairs; keypoints median %.0f; putative matches median %.0f\n", n, num_pairs,
              Median(keypoints), Median(num_matches));
  std::printf("features %.3f s / image; matching %.1f ms / pair (one thread)\n\n", seconds_features / n,
              1000 * seconds_matching / num_pairs);
  std::printf(
      "| variant | ms / pair | ms / edge pair | ms / other pair | edges | rot err median / max deg | "
      "dir err median / max deg | edges > 5 deg off | edges differing from the reference |\n"
      "|---|---|---|---|---|---|---|---|---|\n");
  const std::vector<Variant> variants = {{"ransac, no early rejection (reference)", TwoViewEstimator::kRansac, false},
                                         {"ransac, early rejection", TwoViewEstimator::kRansac, true},
                                         {"ransac, early rejection, refined", TwoViewEstimator::kRansac, true, true},
                                         {"usac (MAGSAC++), no early rejection", TwoViewEstimator::kUsac, false},
                                         {"usac (MAGSAC++), early rejection", TwoViewEstimator::kUsac, true}};
  std::vector<bool> reference_edge(num_pairs, false);
  for (size_t v = 0; v < variants.size(); ++v) {
    ViewGraphOptions o = options;
    o.estimator = variants[v].estimator;
    o.early_rejection = variants[v].early_rejection;
    o.refine_ransac = variants[v].refine_ransac;
    double total = 0, on_edges = 0, on_others = 0;
    int edges = 0, differ = 0, wrong = 0;
    std::vector<double> rot_err, dir_err, rot_err_good;
    long inlier_matches = 0, off_truth = 0;  // kept inlier matches; of them, > 2 px from the true epipolar geometry
    for (int p = 0; p < num_pairs; ++p) {
      const auto [i, j] = pairs[p];
      const double t0 = Now();
      const std::optional<ViewGraphEdge> e =
          EstimateTwoViewGeometry(normalised[i], normalised[j], matches[p], focal, o);
      const double secs = Now() - t0;
      total += secs;
      (e ? on_edges : on_others) += secs;
      if (v == 0) reference_edge[p] = e.has_value();
      differ += e.has_value() != reference_edge[p];
      if (!e) continue;
      ++edges;
      if (!have_truth) continue;
      const Rigid3d truth = cam_from_world[j] * cam_from_world[i].Inverse();
      rot_err.push_back(RotationErrorDeg(e->j_from_i.rotation, truth.rotation));
      wrong += rot_err.back() > kWrongEdgeDeg;
      if (rot_err.back() <= kWrongEdgeDeg) rot_err_good.push_back(rot_err.back());
      const Eigen::Matrix3d e_true = Skew(truth.translation) * truth.RotationMatrix();
      for (const auto& [a, b] : e->inlier_matches) {
        const Eigen::Vector3d xa = normalised[i][a].homogeneous(), xb = normalised[j][b].homogeneous();
        const Eigen::Vector3d ea = e_true * xa, eb = e_true.transpose() * xb;
        const double sampson =
            std::abs(xb.dot(ea)) / std::sqrt(ea.head<2>().squaredNorm() + eb.head<2>().squaredNorm());
        ++inlier_matches;
        off_truth += sampson * focal > 2;
      }
      if (!e->panoramic) {
        const double c =
            std::clamp(e->j_from_i.translation.normalized().dot(truth.translation.normalized()), -1.0, 1.0);
        dir_err.push_back(std::acos(c) * 180 / M_PI);
      }
    }
    const int others = num_pairs - edges;
    std::printf("| %s | %.2f | %.2f | %.2f | %d | %.3f / %.3f | %.2f / %.2f | %d | %d |\n", variants[v].name.c_str(),
                1000 * total / num_pairs, edges ? 1000 * on_edges / edges : NAN,
                others ? 1000 * on_others / others : NAN, edges, Median(rot_err), Max(rot_err), Median(dir_err),
                Max(dir_err), wrong, differ);
    std::printf(
        "|   (edges within 5 deg: rot err median %.3f deg; inlier matches %ld, %ld of them > 2 px off the truth) |\n",
        Median(rot_err_good), inlier_matches, off_truth);
    Json r;
    r["variant"] = variants[v].name;
    r["estimator"] = TwoViewEstimatorName(o.estimator);
    r["early_rejection"] = o.early_rejection;
    r["ms_per_pair"] = 1000 * total / num_pairs;
    r["ms_per_edge_pair"] = edges ? 1000 * on_edges / edges : 0.0;
    r["ms_per_other_pair"] = others ? 1000 * on_others / others : 0.0;
    r["edges"] = edges;
    r["edges_differing_from_reference"] = differ;
    r["edges_over_5deg"] = wrong;
    r["rotation_error_deg_median"] = Median(rot_err);
    r["rotation_error_deg_max"] = Max(rot_err);
    r["rotation_error_deg_median_within_5deg"] = Median(rot_err_good);
    r["inlier_matches"] = inlier_matches;
    r["inlier_matches_over_2px_off_truth"] = off_truth;
    r["direction_error_deg_median"] = Median(dir_err);
    r["direction_error_deg_max"] = Max(dir_err);
    out["variants"].push_back(r);
  }
  if (!json_out.empty()) WriteJsonFile(json_out, out);
  return 0;
}

}  // namespace
}  // namespace nerfreg

int main(int argc, char** argv) { return nerfreg::Run(argc, argv); }
