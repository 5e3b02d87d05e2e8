// `nerfreg dbarf poses` and `dbarf eval-poses` end to end, as a user runs them: a rendered
// forward-facing scene, its images posed from the pixels and the intrinsics alone, then evaluated
// against the renderer's ground truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

#include "cli_test_util.h"
#include "nerfreg/data/colmap.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Pixels of `png` (RGB) within 2/255 of `rgb`: the camera plots' colours (render/camera_plot.h,
// not linked here) survive 8-bit rounding to that precision.
int CountColor(const Image& png, float r, float g, float b) {
  int n = 0;
  for (int y = 0; y < png.height; ++y)
    for (int x = 0; x < png.width; ++x)
      n += std::abs(png.at(x, y, 0) - r) < 2.f / 255 && std::abs(png.at(x, y, 1) - g) < 2.f / 255 &&
           std::abs(png.at(x, y, 2) - b) < 2.f / 255;
  return n;
}

// 12 images of 32x24 pixels: bundle adjustment reaches ~0.2 px on cameras several degrees off
// (4.4 deg median rotation error after aligning rotations, measured). The output must say the
// solution is not well constrained instead of reporting it as posed like any other.
TEST(DbarfCli, TinyImagesAreReportedAsNotWellConstrained) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene"), out = dir.File("poses");
  CommandResult r =
      RunNerfreg("render --procedural 101 --trajectory forward --views 12 --size 32x24 --quiet --out " + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("the poses are not well constrained"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("NOT well constrained"), std::string::npos) << r.output;
  // One log line per stage as it ends, and a summary of them.
  EXPECT_NE(r.output.find("stage features:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stage bundle adjustment:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stages (s): read images"), std::string::npos) << r.output;
  const Json j = ReadJsonFile(out + "/transforms.json");
  EXPECT_FALSE(j["dbarf_poses"]["well_constrained"].get<bool>());
  EXPECT_FALSE(j["dbarf_poses"]["problems"].empty());
  // Posed by the network alone (as auto does where it keeps the network's cameras), the images
  // are as small: still said.
  r = RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --method network --out " +
                 dir.File("network"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("24 px on their short side"), std::string::npos) << r.output;
  EXPECT_FALSE(ReadJsonFile(dir.File("network") + "/transforms.json")["dbarf_poses"]["well_constrained"].get<bool>());
}

TEST(DbarfCli, PosesARenderedForwardFacingSceneAndEvaluatesThem) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene"), out = dir.File("poses");
  CommandResult r = RunNerfreg("render --procedural 5 --trajectory forward --views 10 --quiet --out " + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --quiet --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Dataset est = ReadTransformsJson(out + "/transforms.json");
  ASSERT_EQ(est.frames.size(), 10u);
  CheckImagesMatchCameras(est);  // file_path resolves from OUT to the images
  EXPECT_EQ(est.frames[3].name, "r_003.png");
  // Each image keeps the split --intrinsics gives it: dbarf finetune holds the test views out.
  const Dataset truth = ReadTransformsJson(data + "/transforms.json");
  ASSERT_EQ(truth.frames.size(), 10u);
  ASSERT_FALSE(truth.IndicesOfSplit("test").empty());
  for (size_t k = 0; k < est.frames.size(); ++k) EXPECT_EQ(est.frames[k].split, truth.frames[k].split) << k;
  const Json j = ReadJsonFile(out + "/transforms.json");
  EXPECT_TRUE(j["not_posed"].empty());
  EXPECT_TRUE(j["dbarf_poses"]["well_constrained"].get<bool>()) << j["dbarf_poses"].dump();
  EXPECT_EQ(j["dbarf_poses"]["sift_normalization"], "l1-root");  // posing's default
  // Every stage's wall time, and a total no smaller than their sum (values are not checked:
  // speed is the benchmarks' business, bench/dbarf_speed.sh).
  const Json& times = j["dbarf_poses"]["timings_s"];
  double sum = 0;
  for (const char* stage : {"read images", "load weights", "features", "matching", "geometry", "rotation averaging",
                            "positioning", "tracks", "triangulation", "bundle adjustment", "write output"}) {
    ASSERT_TRUE(times.contains(stage) && times[stage].is_number()) << stage << ": " << times.dump();
    EXPECT_GE(times[stage].get<double>(), 0.0) << stage;
    sum += times[stage].get<double>();
  }
  EXPECT_FALSE(times.contains("network")) << times.dump();  // the SfM posed everything
  EXPECT_GE(times["total"].get<double>(), sum - 1e-6) << times.dump();
  // The run's own peak resident memory, in MB (a process that loaded torch holds tens at least).
  ASSERT_TRUE(j["dbarf_poses"].contains("peak_memory_mb")) << j["dbarf_poses"].dump();
  EXPECT_GT(j["dbarf_poses"]["peak_memory_mb"].get<double>(), 10.0);
  const ColmapModel model = ReadColmapModel(out + "/sparse/0");
  EXPECT_EQ(model.images.size(), 10u);
  EXPECT_GT(model.points3d.size(), 100u);
  // The posed cameras seen from above: 10 red discs (and viewing lines) on white.
  const Image cameras_png = ReadImage(out + "/cameras.png", 3);
  EXPECT_EQ(cameras_png.width, 512);
  EXPECT_EQ(cameras_png.height, 512);
  EXPECT_GT(CountColor(cameras_png, 0.85f, 0.15f, 0.1f), 10 * 30);
  EXPECT_GT(CountColor(cameras_png, 1, 1, 1), 512 * 512 * 9 / 10);

  // Aligned on rotations then centres: with centres this close, a centre-only Umeyama fit adds
  // ~1 deg of its own (measured here: 0.08 deg after the rotation fit, 1.1 deg after Umeyama).
  r = RunNerfreg("dbarf eval-poses " + out + "/transforms.json --ground-truth " + data +
                 "/transforms.json --align rotations --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json e = Json::parse(r.output.substr(r.output.find('{')));
  EXPECT_EQ(e["posed"].get<int>(), 10);
  EXPECT_LT(e["rotation_deg_median"].get<double>(), 0.5) << r.output;
  EXPECT_LT(e["center_percent_median"].get<double>(), 2.0) << r.output;

  // --png: the aligned estimate (red) against the ground truth (blue), seen from above.
  const std::string png = dir.File("eval.png");
  r = RunNerfreg("dbarf eval-poses " + out + "/transforms.json --ground-truth " + data + "/transforms.json --png " +
                 png);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("scale bar"), std::string::npos) << r.output;
  const Image eval_png = ReadImage(png, 3);
  EXPECT_EQ(eval_png.width, 512);
  EXPECT_GT(CountColor(eval_png, 0.85f, 0.15f, 0.1f), 10 * 10);  // red drawn last, over blue
  EXPECT_GT(CountColor(eval_png, 0.1f, 0.3f, 0.9f), 10 * 10);

  // An existing output is refused without --force, replaced with it; --focal works too.
  r = RunNerfreg("dbarf poses " + data + "/images --focal 140.8 --quiet --out " + out);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
  r = RunNerfreg("dbarf poses " + data + "/images --focal 140.8 --quiet --force --out " + out);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(ReadTransformsJson(out + "/transforms.json").IndicesOfSplit("test").empty());  // no file, no splits
}

TEST(DbarfCli, TooFewImagesIsAOneLineErrorNamingTheFolder) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene");
  ASSERT_EQ(RunNerfreg("render --procedural 2 --trajectory forward --views 2 --quiet --out " + data).exit_code, 0);
  const CommandResult r = RunNerfreg("dbarf poses " + data + "/images --focal 100 --out " + dir.File("o"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(data + "/images"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("o")));
}

// Four 128 x 96 forward-facing views of procedural scene 2 in DIR/scene (a motion that pins the
// focal length down poorly).
std::string RenderFourViews(const ScopedTempDir& dir) {
  const std::string data = dir.File("scene");
  const CommandResult r =
      RunNerfreg("render --procedural 2 --trajectory forward --views 4 --test-every 4 --quiet --out " + data);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return data;
}

// Without intrinsics the images are self-calibrated (the focal length written with the poses); an
// image whose size is not its camera's is a one-line error naming it, exit code 2, no output left.
TEST(DbarfCli, MissingIntrinsicsSelfCalibrateAndAnImageOfAnotherSizeIsAOneLineError) {
  ScopedTempDir dir;
  const std::string data = RenderFourViews(dir);
  CommandResult r = RunNerfreg("dbarf poses " + data + "/images --quiet --out " + dir.File("o"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json posed = ReadJsonFile(dir.File("o") + "/transforms.json");
  EXPECT_EQ(posed["dbarf_poses"]["intrinsics"], "self-calibrated");
  EXPECT_EQ(posed["dbarf_poses"]["posed"].get<int>(), 4);
  // The refined focal length is written (its accuracy: GlobalSfm.SelfCalibration*; four 128 x 96
  // views pin it down poorly)...
  ASSERT_TRUE(posed.contains("fl_x")) << posed.dump();
  EXPECT_GT(posed["fl_x"].get<double>(), 0);
  // ...and the run says so: the focal's standard deviation is written, and above 1 % of it warned.
  const Json& calibration = posed["dbarf_poses"]["self_calibration"];
  ASSERT_EQ(calibration.size(), 1u) << posed["dbarf_poses"].dump();
  EXPECT_NEAR(calibration[0]["focal_px"].get<double>(), posed["fl_x"].get<double>(), 1e-6);
  EXPECT_FALSE(calibration[0]["determined"].get<bool>()) << calibration.dump();
  EXPECT_NE(r.output.find("focal length poorly determined"), std::string::npos) << r.output;

  const Json t = ReadJsonFile(data + "/transforms.json");
  std::string first = t["frames"][1]["file_path"].get<std::string>();
  if (std::filesystem::path(first).extension().empty()) first += ".png";
  const std::string image = data + "/" + first;
  const Image original = ReadImage(image);
  WriteImage(image, Image(original.width / 2, original.height / 2, 3));
  r = RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --out " + dir.File("p"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(std::filesystem::path(first).filename().string()), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("p")));
  r = RunNerfreg("dbarf eval " + data + "/transforms.json --out " + dir.File("e"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(std::filesystem::path(first).filename().string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("size"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("e")));
}

// Photos whose EXIF gives the focal (35 mm equivalent) but whose motion leaves it free (four
// 128 x 96 views: refined from the prior it ended 19 % above the truth, +- 14 %): the EXIF focal
// is kept, held, and the output says so (SfmOptions::hold_focal_prior_above).
TEST(DbarfCli, AnExifFocalIsHeldWhereThePhotosLeaveTheFocalFree) {
  ScopedTempDir dir;
  const std::string data = RenderFourViews(dir);
  const double truth = ReadJsonFile(data + "/transforms.json")["fl_x"].get<double>();
  const std::string photos = dir.File("photos");
  std::filesystem::create_directories(photos);
  TestExif exif;
  exif.make = "Test";
  exif.model = "Camera";
  exif.focal_length_35mm = static_cast<std::uint16_t>(std::lround(truth * 36 / 128));
  for (const auto& e : std::filesystem::directory_iterator(data + "/images"))
    WriteJpegWithExif(photos + "/" + e.path().stem().string() + ".jpg", ReadImage(e.path().string()), exif);
  const CommandResult r = RunNerfreg("dbarf poses " + photos + " --out " + dir.File("o"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json posed = ReadJsonFile(dir.File("o") + "/transforms.json");
  const double prior = *exif.focal_length_35mm / 36.0 * 128;
  EXPECT_NEAR(posed["fl_x"].get<double>(), prior, 1e-9);
  EXPECT_NEAR(posed["fl_x"].get<double>(), truth, 0.02 * truth);  // the EXIF's rounding to 1 mm
  const Json& calibration = posed["dbarf_poses"]["self_calibration"];
  ASSERT_EQ(calibration.size(), 1u) << posed["dbarf_poses"].dump();
  EXPECT_TRUE(calibration[0]["held_at_prior"].get<bool>()) << calibration.dump();
  EXPECT_FALSE(calibration[0]["determined"].get<bool>());
  EXPECT_GT(calibration[0]["focal_stddev_px"].get<double>(), 0.05 * prior);
  EXPECT_NE(r.output.find("EXIF's"), std::string::npos) << r.output;
  EXPECT_EQ(posed["dbarf_poses"]["posed"].get<int>(), 4);
}

// A box blur of radius `r`, `passes` times (about a Gaussian of sigma r * sqrt(passes / 3)): what a
// badly focused photo looks like, with too little texture left for SIFT.
Image Blurred(const Image& in, int r, int passes) {
  Image a = in;
  for (int p = 0; p < passes; ++p)
    for (int axis = 0; axis < 2; ++axis) {
      Image b = a;
      for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
          for (int c = 0; c < a.channels; ++c) {
            float sum = 0;
            for (int d = -r; d <= r; ++d) {
              const int xx = axis == 0 ? std::clamp(x + d, 0, a.width - 1) : x;
              const int yy = axis == 1 ? std::clamp(y + d, 0, a.height - 1) : y;
              sum += a.at(xx, yy, c);
            }
            b.at(x, y, c) = sum / (2 * r + 1);
          }
      a = std::move(b);
    }
  return a;
}

const Json* FrameNamed(const Json& transforms, const std::string& name) {
  for (const Json& f : transforms["frames"])
    if (std::filesystem::path(f["file_path"].get<std::string>()).filename() == name) return &f;
  return nullptr;
}

// --method auto: an image the SfM cannot pose (blurred: no matches) is posed by the network against
// its SfM-posed neighbours; the others keep their classical cameras, and each frame says which
// method posed it.
TEST(DbarfCli, AutoPosesWithTheNetworkAnImageTheSfmCannotPose) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene");
  CommandResult r = RunNerfreg("render --procedural 5 --trajectory forward --views 8 --quiet --out " + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string blurred = data + "/images/r_004.png";
  WriteImage(blurred, Blurred(ReadImage(blurred, 3), 4, 3));
  const std::string args = "dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --quiet --out ";

  r = RunNerfreg(args + dir.File("classical") + " --method classical");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json classical = ReadJsonFile(dir.File("classical") + "/transforms.json");
  ASSERT_EQ(classical["not_posed"].size(), 1u) << classical["not_posed"].dump();
  EXPECT_EQ(classical["not_posed"][0].get<std::string>(), "r_004.png");

  r = RunNerfreg(args + dir.File("auto") + " --method auto");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = ReadJsonFile(dir.File("auto") + "/transforms.json");
  EXPECT_TRUE(j["not_posed"].empty()) << j["not_posed"].dump();
  ASSERT_EQ(j["frames"].size(), 8u);
  EXPECT_EQ(j["dbarf_poses"]["posed_by_network"].get<int>(), 1);
  EXPECT_TRUE(j["dbarf_poses"]["timings_s"].contains("network")) << j["dbarf_poses"].dump();
  EXPECT_TRUE(classical["dbarf_poses"]["timings_s"].contains("bundle adjustment")) << classical["dbarf_poses"].dump();
  EXPECT_FALSE(classical["dbarf_poses"]["timings_s"].contains("load weights")) << classical["dbarf_poses"].dump();
  for (const Json& f : j["frames"]) {
    const bool is_blurred = std::filesystem::path(f["file_path"].get<std::string>()).filename() == "r_004.png";
    EXPECT_EQ(f["posed_by"].get<std::string>(), is_blurred ? "network" : "sfm") << f.dump();
    EXPECT_TRUE(f["confidence"].contains("rotation_residual_deg")) << f.dump();
    EXPECT_EQ(f["confidence"].contains("observations"), !is_blurred) << f.dump();
  }
  // The pairs the network was run on join the view graph (0 inliers), so dbarf finetune / render
  // find neighbours for the image the matcher could not relate.
  int blurred_edges = 0;
  for (const Json& e : j["view_graph"])
    blurred_edges += e[0].get<std::string>() == "r_004.png" || e[1].get<std::string>() == "r_004.png";
  EXPECT_EQ(blurred_edges, 5) << j["view_graph"].dump();
  // Images whose confidence is low are listed (and named in a warning).
  int num_low = 0;
  for (const Json& f : j["frames"]) num_low += f["confidence"]["low"].get<bool>();
  EXPECT_EQ(j["low_confidence"].size(), static_cast<size_t>(num_low));
  // The classical cameras are kept as they were.
  for (const std::string name : {"r_000.png", "r_003.png", "r_007.png"})
    EXPECT_EQ((*FrameNamed(j, name))["transform_matrix"], (*FrameNamed(classical, name))["transform_matrix"]) << name;

  // The network's camera is near its true place: its rotation relative to its neighbours' (frame-
  // independent) within a few degrees, and its centre, once the SfM's cameras are brought onto the
  // truth by a similarity, within half the distance to its nearest neighbour. (A test that asked for
  // the centre between its neighbours' failed the truth itself: on this trajectory r_004 lies 1.2
  // half-spacings off the midpoint of r_003 and r_005.)
  const Dataset est = ReadTransformsJson(dir.File("auto") + "/transforms.json");
  const Dataset gt = ReadTransformsJson(data + "/transforms.json");
  const auto pose_of = [](const Dataset& d, const std::string& name) {
    for (const Frame& f : d.frames)
      if (f.name == name) return f.cam_from_world;
    ADD_FAILURE() << name;
    return Rigid3d();
  };
  for (const std::string other : {"r_003.png", "r_005.png"}) {
    const Eigen::Quaterniond e = pose_of(est, "r_004.png").rotation * pose_of(est, other).rotation.conjugate();
    const Eigen::Quaterniond g = pose_of(gt, "r_004.png").rotation * pose_of(gt, other).rotation.conjugate();
    EXPECT_LT(RotationErrorDeg(e, g), 3.0) << other;
  }
  const std::vector<std::string> sfm_names = {"r_000.png", "r_001.png", "r_002.png", "r_003.png",
                                              "r_005.png", "r_006.png", "r_007.png"};
  Eigen::Matrix3Xd est_centres(3, sfm_names.size()), gt_centres(3, sfm_names.size());
  for (size_t k = 0; k < sfm_names.size(); ++k) {
    est_centres.col(k) = pose_of(est, sfm_names[k]).Inverse().translation;
    gt_centres.col(k) = pose_of(gt, sfm_names[k]).Inverse().translation;
  }
  AlignmentOptions align;
  align.estimate_scale = true;
  Sim3d gt_from_est;
  ASSERT_TRUE(EstimateSim3d(est_centres, gt_centres, Eigen::VectorXd(), align, &gt_from_est));
  const Eigen::Vector3d c4 = gt_from_est * pose_of(est, "r_004.png").Inverse().translation;
  const Eigen::Vector3d g4 = pose_of(gt, "r_004.png").Inverse().translation;
  double nearest = 1e30;
  for (const std::string other : {"r_003.png", "r_005.png"})
    nearest = std::min(nearest, (pose_of(gt, other).Inverse().translation - g4).norm());
  EXPECT_LT((c4 - g4).norm(), 0.5 * nearest) << c4.transpose() << " | truth " << g4.transpose();
}

// A hard set of the bench's (bench/dbarf_poses_bench.py): 10 forward-facing 128x96 views of
// procedural scene `seed` with `material`, rendered into DIR/scene.
std::string RenderHardSet(const ScopedTempDir& dir, int seed, const std::string& material) {
  const std::string data = dir.File("scene");
  const CommandResult r = RunNerfreg("render --procedural " + std::to_string(seed) +
                                     " --trajectory forward --views 10 --size 128x96 --material " + material +
                                     " --test-every 0 --quiet --out " + data);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return data;
}

// dbarf eval-poses' median rotation error of OUT/transforms.json against DATA's truth.
double MedianRotationError(const std::string& out, const std::string& data) {
  const CommandResult e = RunNerfreg("dbarf eval-poses " + out + "/transforms.json --ground-truth " + data +
                                     "/transforms.json --align rotations --json");
  EXPECT_EQ(e.exit_code, 0) << e.output;
  return Json::parse(e.output.substr(e.output.find('{')))["rotation_deg_median"].get<double>();
}

// --method auto on repetitive texture: the SfM poses every image but matches the wrong copies of
// the pattern, doubts its own solution (here 6 of 10 images) though it calls it well constrained,
// and auto poses all images with the network too, keeping the cameras with the lower photometric
// error. Both errors are recorded, the network's cameras are kept, and they are closer to the truth
// than the SfM's (a held-out seed of the bench's repetitive sets, bench/dbarf_poses_bench.py; until
// 2026-11-29 a well-constrained SfM was never put to the test, and auto kept it, 2.39 deg off).
// Without keypoint refinement: with it the SfM poses this set within 0.3 deg (the next test).
// OpenCV's L2 descriptors, with which the SfM fails here (RootSIFT's, the default since
// 2026-11-30, match this set otherwise).
TEST(DbarfCli, AutoReplacesADoubtfulSfmOnRepetitiveTextureByTheNetwork) {
  ScopedTempDir dir;
  const std::string data = RenderHardSet(dir, 5504, "repetitive");
  const std::string args = "dbarf poses " + data + "/images --intrinsics " + data +
                           "/transforms.json --no-keypoint-refinement --sift-normalization l2 --quiet --out ";
  CommandResult r = RunNerfreg(args + dir.File("classical") + " --method classical");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json classical = ReadJsonFile(dir.File("classical") + "/transforms.json");
  EXPECT_TRUE(classical["dbarf_poses"]["well_constrained"].get<bool>()) << classical["dbarf_poses"].dump();
  EXPECT_GE(classical["low_confidence"].size(), 3u) << classical.dump();
  r = RunNerfreg(args + dir.File("auto") + " --method auto");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = ReadJsonFile(dir.File("auto") + "/transforms.json");
  EXPECT_EQ(j["dbarf_poses"]["sift_normalization"], "l2");
  ASSERT_TRUE(j["dbarf_poses"].contains("auto_check")) << j["dbarf_poses"].dump();
  const Json& check = j["dbarf_poses"]["auto_check"];
  EXPECT_EQ(check["kept"], "network") << check.dump();
  EXPECT_LT(check["network_photometric_error"].get<double>(), check["sfm_photometric_error"].get<double>());
  for (const Json& f : j["frames"]) EXPECT_EQ(f["posed_by"], "network") << f.dump();
  const double sfm_error = MedianRotationError(dir.File("classical"), data),
               auto_error = MedianRotationError(dir.File("auto"), data);
  EXPECT_LT(auto_error, sfm_error) << "auto " << auto_error << " deg, classical " << sfm_error << " deg";
}

// The same repetitive set with and without keypoint refinement: SIFT's own positions give an SfM
// 2.39 deg off, the keypoints aligned on the images 0.29 deg (why so much is not established).
// With OpenCV's L2 descriptors: with RootSIFT's SIFT's own positions give 0.61 deg here.
TEST(DbarfCli, KeypointRefinementPosesTheRepetitiveSetTheSfmGotWrong) {
  ScopedTempDir dir;
  const std::string data = RenderHardSet(dir, 5504, "repetitive");
  const std::string args = "dbarf poses " + data + "/images --intrinsics " + data +
                           "/transforms.json --method classical --sift-normalization l2 --quiet --out ";
  ASSERT_EQ(RunNerfreg(args + dir.File("refined")).exit_code, 0);
  ASSERT_EQ(RunNerfreg(args + dir.File("sift") + " --no-keypoint-refinement").exit_code, 0);
  const double refined = MedianRotationError(dir.File("refined"), data),
               sift = MedianRotationError(dir.File("sift"), data);
  EXPECT_LT(refined, 1.0);
  EXPECT_GT(sift, 1.5);
}

// --method auto where the SfM poses none of a low-texture set (a held-out seed of the bench's):
// the network poses all, and the view graph's few edges averaged in at weight 10 put 9 of the 10
// centres onto one point. auto then poses them with the network alone and keeps the answer whose
// centres do not collapse: no image is low-confidence for a collapse, and the rotations come within
// a few degrees of the truth (1.5 deg; the collapsed answer could not be scored at all). With
// OpenCV's L2 descriptors, with which the SfM poses none of this set.
TEST(DbarfCli, AutoDropsTheViewGraphsEdgesWhereTheyCollapseTheNetworksCameras) {
  ScopedTempDir dir;
  const std::string data = RenderHardSet(dir, 5404, "low-texture");
  const CommandResult r =
      RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data +
                 "/transforms.json --method auto --sift-normalization l2 --out " + dir.File("auto"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("camera centres onto others'; without them: 0"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("a collapsed solution"), std::string::npos) << r.output;
  EXPECT_LT(MedianRotationError(dir.File("auto"), data), 3.0);
}

// Method network on a low-texture set (seed 7008) where it puts 4 camera centres onto others' whose
// SIFT matches show parallax (the photos were not taken from one spot): those cameras are a
// collapsed solution, so they are not posed, each with the reason, and never written as posed
// (issue 42). Centres that coincide where no matches tell are posed, low-confidence.
TEST(DbarfCli, NetworkCamerasCollapsedOntoOthersDespiteParallaxAreNotPosed) {
  ScopedTempDir dir;
  const std::string data = RenderHardSet(dir, 7008, "low-texture");
  const CommandResult r = RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data +
                                     "/transforms.json --method network --out " + dir.File("net"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json posed = ReadJsonFile(dir.File("net") + "/transforms.json");
  const Json& not_posed = posed["not_posed"];
  ASSERT_GE(not_posed.size(), 1u) << r.output;
  EXPECT_EQ(posed["frames"].size() + not_posed.size(), 10u);
  for (const Json& name : not_posed) {
    const std::string line = name.get<std::string>() + ": not posed (the network put its camera centre onto ";
    EXPECT_NE(r.output.find(line), std::string::npos) << line << "\n" << r.output;
  }
  EXPECT_NE(r.output.find("although their matches show parallax (a collapsed solution)"), std::string::npos);
  for (const Json& f : posed["frames"]) {
    const std::string name = std::filesystem::path(f["file_path"].get<std::string>()).filename().string();
    for (const Json& n : not_posed) EXPECT_NE(name, n.get<std::string>());
  }
}

// Images no method can pose with confidence (a flat grey one, two identical, one of another scene
// drawn upside down): each is posed or not, but never a confident pose; the warning names each
// with its confidence and the reason. A weights file of another kind is a named error.
TEST(DbarfCli, TexturelessIdenticalAndUnrelatedImagesAreNamedInAWarningNeverConfident) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene"), other = dir.File("other");
  ASSERT_EQ(RunNerfreg("render --procedural 5011 --trajectory forward --views 8 --quiet --out " + data).exit_code, 0);
  ASSERT_EQ(
      RunNerfreg("render --procedural 5012 --trajectory forward --views 1 --material repetitive --quiet --out " + other)
          .exit_code,
      0);
  Image grey = ReadImage(data + "/images/r_002.png", 3);
  for (float& v : grey.data) v = 0.5f;
  WriteImage(data + "/images/r_002.png", grey);
  std::filesystem::copy_file(data + "/images/r_004.png", data + "/images/r_005.png",
                             std::filesystem::copy_options::overwrite_existing);
  const Image unrelated = ReadImage(other + "/images/r_000.png", 3);
  Image flipped = unrelated;
  for (int y = 0; y < unrelated.height; ++y)
    for (int x = 0; x < unrelated.width; ++x)
      for (int c = 0; c < 3; ++c)
        flipped.at(x, y, c) = unrelated.at(unrelated.width - 1 - x, unrelated.height - 1 - y, c);
  WriteImage(data + "/images/r_007.png", flipped);

  const CommandResult r =
      RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --out " + dir.File("o"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = ReadJsonFile(dir.File("o") + "/transforms.json");
  const std::map<std::string, std::string> expected = {{"r_002.png", "textureless"},
                                                       {"r_004.png", "identical to r_005.png"},
                                                       {"r_005.png", "identical to r_004.png"},
                                                       {"r_007.png", "unrelated"}};
  for (const auto& [name, problem] : expected) {
    const Json* f = FrameNamed(j, name);
    if (f == nullptr) {  // not posed at all: listed as such
      EXPECT_NE(j["not_posed"].dump().find(name), std::string::npos) << name;
      continue;
    }
    EXPECT_TRUE((*f)["confidence"]["low"].get<bool>()) << f->dump();
    EXPECT_EQ((*f)["confidence"].value("problem", ""), problem) << f->dump();
    EXPECT_NE(j["low_confidence"].dump().find(name), std::string::npos) << name;
    // The warning names it with its confidence and the reason.
    EXPECT_NE(r.output.find(name + " ("), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(problem + ")"), std::string::npos) << r.output;
  }
  EXPECT_NE(r.output.find("low-confidence poses"), std::string::npos) << r.output;

  // Weights that are not DBARF weights (here a transforms.json) are a one-line error naming the file.
  const CommandResult w =
      RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data +
                 "/transforms.json --method network --weights " + data + "/transforms.json --out " + dir.File("w"));
  EXPECT_EQ(w.exit_code, 2) << w.output;
  EXPECT_NE(w.output.find("error: " + data + "/transforms.json"), std::string::npos) << w.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("w")));
}

}  // namespace
}  // namespace nerfreg
