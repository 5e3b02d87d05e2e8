// `nerfreg dbarf pretrain / finetune / render / eval` end to end on a tiny rendered scene, as a user
// runs them: the scene is posed from its images, DBARF trains a few steps (and resumes), renders
// views at the estimated cameras, and is evaluated against the renderer's ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "cli_test_util.h"
#include "nerfreg/data/npy.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

int CountLines(const std::string& path) {
  std::ifstream in(path);
  int n = 0;
  for (std::string line; std::getline(in, line);) n += !line.empty();
  return n;
}

// A tiny rendered scene (10 views, 2 test views) posed by dbarf poses.
struct PosedScene {
  ScopedTempDir dir;
  std::string data = dir.File("scene"), posed = dir.File("posed");
  Json poses;
  void Make() {
    CommandResult r = RunNerfreg(
        "render --procedural 7 --trajectory forward --views 10 --test-every 5 --depth --quiet --out " + data);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --quiet --out " + posed);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    poses = ReadJsonFile(posed + "/transforms.json");
  }
};

const char* kTinyTraining = " --stage-steps 2 --rays 48 --sources 2 --checkpoint-every 2 --quiet";

TEST(DbarfTrainCli, PretrainThenResume) {
  PosedScene s;
  ASSERT_NO_FATAL_FAILURE(s.Make());
  EXPECT_GT(s.poses["dbarf_poses"]["far"].get<double>(), s.poses["dbarf_poses"]["near"].get<double>());
  EXPECT_GE(s.poses["view_graph"].size(), 9u);
  const std::string w = s.dir.File("w.pt"), train = kTinyTraining;
  // Pretrain 4 steps (stages of 2: pose, nerf), then resume to 6 (pose again).
  CommandResult r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --steps 4 --out " + w + train);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(CountLines(w + ".log.jsonl"), 4);
  r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --steps 4 --out " + w + train);
  EXPECT_NE(r.exit_code, 0);  // exists: --force or --resume
  // As if the run had gone on past its checkpoint and been killed mid-line: the resumed run logs
  // step 5 again, so the log drops the stale step and the half line first.
  {
    std::ofstream stale(w + ".log.jsonl", std::ios::app);
    stale << "{\"step\":5,\"stage\":\"stale\"}\n{\"step\":6,\"sta";
  }
  r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --steps 6 --resume --out " + w + train);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(CountLines(w + ".log.jsonl"), 6);
  EXPECT_EQ(ReadFileToString(w + ".log.jsonl").find("stale"), std::string::npos);
  const Json summary = ReadJsonFile(w + ".json");
  EXPECT_EQ(summary["steps"].get<int>(), 6);
  // Continue pretraining from those weights in a new run, with perturbed camera initialisations.
  const std::string w2 = s.dir.File("w2.pt");
  r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --weights " + w + " --steps 2 --init-noise-deg 1 " +
                 "--init-noise-translation 0.05 --out " + w2 + train);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(CountLines(w2 + ".log.jsonl"), 2);
  r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --steps 2 --init-noise-deg 45 --out " +
                 s.dir.File("w3.pt") + train);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--init-noise-deg"), std::string::npos) << r.output;
  // Self-supervised from the identity with those weights' encoders and fresh heads, the SfM loss
  // over a 2-level pyramid; fresh heads need weights to keep the encoders of.
  const std::string w4 = s.dir.File("w4.pt");
  r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --weights " + w + " --steps 2 --pose-init network " +
                 "--fresh-pose-heads --sfm-levels 2 --out " + w4 + train);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(CountLines(w4 + ".log.jsonl"), 2);
  r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --steps 2 --fresh-pose-heads --out " +
                 s.dir.File("w5.pt") + train);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("error: --fresh-pose-heads: expected --weights"), std::string::npos) << r.output;
  EXPECT_FALSE(FileExists(s.dir.File("w5.pt")));
}

TEST(DbarfTrainCli, SupervisedPosesFromTheIdentityAndEvalNet) {
  PosedScene s;
  ASSERT_NO_FATAL_FAILURE(s.Make());
  const std::string w = s.dir.File("sup.pt");
  // The dataset (ground truth kept aside, cameras estimated), pose stage from the identity.
  CommandResult r =
      RunNerfreg("dbarf pretrain " + s.data + "/transforms.json --pose-init network --supervise-poses 1 " +
                 "--rotation-scale 1 --steps 2 --out " + w + kTinyTraining);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream log(w + ".log.jsonl");
  std::string line;
  ASSERT_TRUE(std::getline(log, line));
  const Json first = Json::parse(line);
  EXPECT_GT(first["pose_loss"].get<double>(), 0.0) << line;
  EXPECT_GE(first["rot_err_deg"].get<double>(), 0.0) << line;
  // Posed images written by dbarf poses carry no ground truth to supervise with.
  r = RunNerfreg("dbarf pretrain " + s.posed + "/transforms.json --supervise-poses 1 --steps 2 --out " +
                 s.dir.File("bad.pt") + kTinyTraining);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--supervise-poses"), std::string::npos) << r.output;
  // eval-net: per-dataset rows; an untrained network from the identity stays at the identity's error.
  r = RunNerfreg("dbarf eval-net " + s.data + "/transforms.json --weights " + w + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json e = Json::parse(r.output.substr(r.output.rfind("{\"datasets\"")));  // the last line
  EXPECT_EQ(e["rows"].size(), 1u);
  EXPECT_GT(e["start_rotation_deg"].get<double>(), 0.0);
  EXPECT_NEAR(e["start_translation_direction_deg"].get<double>(), 90.0, 1e-6);
  // The network's depth as a normalised disparity; |t| / |t_true| only where the truth is in the
  // depth range's units (ground-truth scene cameras), which estimated cameras are not.
  EXPECT_GE(e["disparity"].get<double>(), 0.0);
  EXPECT_LE(e["disparity"].get<double>(), 1.0);
  EXPECT_FALSE(e.contains("translation_ratio"));
}

// What models/dbarf_pose_cpu.pt must reach on the held-out scene below from the identity: the
// rotation error cut by at least 70 % (the bar; it reaches 3.436 -> 0.940 deg, a 73 %
// cut, with batch statistics in its BatchNorm layers; the weights shipped before 2026-11-26 07:00
// reached 0.580 here but were worse on the validation and test sets), the translation direction
// below 8 deg (4.24 deg). Its model card has the figures.
constexpr double kPoseRotationKept = 0.3;
constexpr double kPoseDirectionBelow = 8.0;

// The shipped pose weights pose a held-out scene (seed 4001: not a training, validation or test
// scene) from the identity; the weights trained for camera initialisations do not.
TEST(DbarfTrainCli, ShippedPoseWeightsPoseFromTheIdentity) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene");
  CommandResult r =
      RunNerfreg("render --procedural 4001 --trajectory forward --views 20 --test-every 8 --quiet --out " + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto eval = [&](const std::string& weights) {
    const CommandResult e = RunNerfreg("dbarf eval-net " + data + "/transforms.json --json --weights " +
                                       std::string(NERFREG_SOURCE_DIR) + "/models/" + weights);
    EXPECT_EQ(e.exit_code, 0) << e.output;
    return Json::parse(e.output.substr(e.output.rfind("{\"datasets\"")));
  };
  const Json trained = eval("dbarf_pose_cpu.pt"), untrained = eval("dbarf_cpu.pt");
  const double start = trained["start_rotation_deg"].get<double>();
  EXPECT_GT(start, 1.0);
  EXPECT_LT(trained["rotation_deg"].get<double>(), kPoseRotationKept * start);
  EXPECT_LT(trained["translation_direction_deg"].get<double>(), kPoseDirectionBelow);
  EXPECT_GT(untrained["rotation_deg"].get<double>(), kPoseRotationKept * start);
  EXPECT_GT(untrained["translation_direction_deg"].get<double>(), kPoseDirectionBelow);
}

// The paper's per-scene finetune, self-supervised (the SfM loss alone, from the identity), on a
// small render with hand-held LLFF-like motion: the shipped pose weights, trained on look-at scenes,
// start worse than the identity there (4.74 deg against 2.91 when written); 300 steps take them
// below both (2.24) and lower the loss. The translations do not learn (results/dbarf_self_supervised.md).
TEST(DbarfTrainCli, PerSceneSelfSupervisedFinetuneLowersTheRotationErrorAndTheLoss) {
  ScopedTempDir dir;
  const std::string data = dir.File("llff"), w = dir.File("scene.pt");
  CommandResult r = RunNerfreg(
      "render --procedural 77 --trajectory llff --views 10 --size 64x48 --material textured --spread 0 --quiet --out " +
      data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string start = std::string(NERFREG_SOURCE_DIR) + "/models/dbarf_pose_cpu.pt";
  const auto eval = [&](const std::string& weights) {
    const CommandResult e = RunNerfreg("dbarf eval-net " + data +
                                       "/transforms.json --json --scene-cameras ground-truth --weights " + weights);
    EXPECT_EQ(e.exit_code, 0) << e.output;
    return Json::parse(e.output.substr(e.output.rfind("{\"datasets\"")));
  };
  r = RunNerfreg("dbarf pretrain " + data + "/transforms.json --config cpu --pose-init network --weights " + start +
                 " --stage-steps 1000000000 --steps 300 --supervise-poses 0 --supervise-depth 0 --augment-blur 0 "
                 "--rotation-scale 1 --lr-pose 2e-4 --sfm-levels 2 --checkpoint-every 1000 "
                 "--scene-cameras ground-truth --quiet --out " +
                 w);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json before = eval(start), after = eval(w);
  const double identity = before["start_rotation_deg"].get<double>();
  EXPECT_GT(before["rotation_deg"].get<double>(), identity);
  EXPECT_LT(after["rotation_deg"].get<double>(), 0.7 * before["rotation_deg"].get<double>());
  EXPECT_LT(after["rotation_deg"].get<double>(), 0.9 * identity);
  // The SfM loss over the last 50 steps against the first 50.
  std::vector<double> loss;
  std::istringstream log(ReadFileToString(w + ".log.jsonl"));
  for (std::string line; std::getline(log, line);) loss.push_back(Json::parse(line)["sfm_loss"].get<double>());
  ASSERT_EQ(loss.size(), 300u);
  const auto mean = [&](size_t from) {
    double sum = 0;
    for (size_t i = from; i < from + 50; ++i) sum += loss[i];
    return sum / 50;
  };
  EXPECT_LT(mean(250), 0.9 * mean(0));
}

TEST(DbarfTrainCli, FinetuneRenderAndEval) {
  PosedScene s;
  ASSERT_NO_FATAL_FAILURE(s.Make());
  const std::string shipped = std::string(NERFREG_SOURCE_DIR) + "/models/dbarf_cpu.pt", ft = s.dir.File("ft.pt");
  // Finetune the shipped weights on the dataset itself (its poses are not used).
  CommandResult r = RunNerfreg("dbarf finetune " + s.data + "/transforms.json --weights " + shipped +
                               " --steps 2 --out " + ft + kTinyTraining);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(ft));

  // Render one of the posed cameras.
  Json one = s.poses;
  one["frames"] = Json::array({s.poses["frames"][1]});
  WriteJsonFile(s.posed + "/one.json", one);
  r = RunNerfreg("dbarf render " + s.posed + "/transforms.json --transforms " + s.posed + "/one.json --weights " + ft +
                 " --sources 2 --quiet --out " + s.dir.File("novel"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string name = s.poses["frames"][1]["file_path"].get<std::string>();
  const std::string png = std::filesystem::path(name).filename().replace_extension(".png").string();
  const Image view = ReadImage(s.dir.File("novel/" + png));
  EXPECT_EQ(view.width, 128);
  EXPECT_EQ(view.height, 96);
  EXPECT_TRUE(std::filesystem::exists(s.dir.File("novel/depth/" + png)));

  // Evaluate: every image posed, both test views rendered with finite scores.
  r = RunNerfreg("dbarf eval " + s.data + "/transforms.json --weights " + ft + " --sources 2 --json --quiet --out " +
                 s.dir.File("eval") + " --perturb-deg 2 --perturb-translation 0.1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json e = ReadJsonFile(s.dir.File("eval/eval.json"));
  // The perturbed rows: the same worse initialisation for the cameras and the network.
  const Json& rel = e["relative_poses"];
  EXPECT_GT(rel["perturbed"]["cameras"]["rotation_deg"].get<double>(),
            rel["cameras"]["rotation_deg"].get<double>() + 1.0)
      << rel.dump();
  EXPECT_EQ(rel["perturbed"]["network"]["pairs"], rel["network"]["pairs"]);
  EXPECT_EQ(e["posed"].get<int>(), 10);
  EXPECT_EQ(e["rendered"].get<int>(), 2);
  EXPECT_LT(e["rotation_deg_median"].get<double>(), 0.5);
  EXPECT_GT(e["psnr_mean"].get<double>(), 15.0);
  EXPECT_TRUE(std::filesystem::exists(s.dir.File("eval/compare.png")));
  // The dataset has depth maps (render --depth): the rendered views' depths are scored against
  // them, per view and as a median.
  ASSERT_TRUE(e["depth_error_median"].is_number()) << e.dump();
  const double depth_error = e["depth_error_median"].get<double>();
  EXPECT_GT(depth_error, 0.0);
  EXPECT_LT(depth_error, 0.5);
  EXPECT_TRUE(e["views"][0].contains("depth_error")) << e["views"].dump();

  // The depth maps turned upside down: the same depths, at the wrong pixels, score worse (the
  // error measures geometry, not the spread of depths). Then a truncated map is a one-line error.
  std::vector<std::string> maps;
  for (const auto& f : std::filesystem::directory_iterator(s.data + "/depth")) maps.push_back(f.path().string());
  ASSERT_FALSE(maps.empty());
  for (const std::string& m : maps) {
    std::filesystem::copy_file(m, m + ".kept");
    NpyArray a = ReadNpy(m);
    const int64_t h = a.shape[0], w = a.shape[1];
    NpyArray flipped = a;
    for (int64_t y = 0; y < h; ++y)
      for (int64_t x = 0; x < w; ++x) flipped.data[y * w + x] = a.data[(h - 1 - y) * w + x];
    std::filesystem::remove(m);
    WriteNpy(m, flipped);
  }
  r = RunNerfreg("dbarf eval " + s.data + "/transforms.json --weights " + ft + " --sources 2 --out " +
                 s.dir.File("eval_flipped"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("rendered depth"), std::string::npos) << r.output;
  EXPECT_GT(ReadJsonFile(s.dir.File("eval_flipped/eval.json"))["depth_error_median"].get<double>(), 1.5 * depth_error);
  for (const std::string& m : maps) {
    std::filesystem::remove(m);
    std::ofstream(m) << "\x93NUMPY";
  }
  r = RunNerfreg("dbarf eval " + s.data + "/transforms.json --weights " + ft + " --sources 2 --quiet --out " +
                 s.dir.File("eval_truncated"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("error: " + s.data + "/depth/"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(s.dir.File("eval_truncated")));
  for (const std::string& m : maps) {
    std::filesystem::remove(m);
    std::filesystem::rename(m + ".kept", m);
  }

  // The cameras of dbarf poses given with --cameras are scored by the same protocol: here they are
  // what eval estimated itself (the same SfM), so the figures agree.
  r = RunNerfreg("dbarf eval " + s.data + "/transforms.json --cameras " + s.posed + "/transforms.json --weights " + ft +
                 " --sources 2 --json --quiet --out " + s.dir.File("eval_given"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json given = ReadJsonFile(s.dir.File("eval_given/eval.json"));
  EXPECT_EQ(given["posed"], e["posed"]);
  EXPECT_EQ(given["rendered"], e["rendered"]);
  EXPECT_NEAR(given["rotation_deg_median"].get<double>(), e["rotation_deg_median"].get<double>(), 0.05);
  EXPECT_NEAR(given["psnr_mean"].get<double>(), e["psnr_mean"].get<double>(), 0.5);
  // A file that dbarf poses did not write is refused.
  r = RunNerfreg("dbarf eval " + s.data + "/transforms.json --cameras " + s.data + "/transforms.json --weights " + ft +
                 " --quiet --out " + s.dir.File("eval_bad"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("error: " + s.data + "/transforms.json"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(s.dir.File("eval_bad")));
}

// The finetune's camera refinement: cameras that dbarf poses got right, each turned by 2 degrees
// about its own centre (as a poor initialisation might be), come back closer to the truth after a
// short finetune on the tiny scene.
TEST(DbarfTrainCli, ShortFinetuneLowersThePoseErrorOfPerturbedCameras) {
  PosedScene s;
  ASSERT_NO_FATAL_FAILURE(s.Make());
  Json perturbed = s.poses;
  for (size_t k = 0; k < perturbed["frames"].size(); ++k) {
    Json& m = perturbed["frames"][k]["transform_matrix"];
    const Eigen::Vector3d axis = Eigen::Vector3d(std::sin(1.0 + 2.0 * k), std::cos(3.0 * k), 0.5).normalized();
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(2.0 * M_PI / 180.0, axis).toRotationMatrix();
    Eigen::Matrix3d r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = m[i][j].get<double>();
    r = r * turn;  // camera-to-world: turns the camera about its centre
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m[i][j] = r(i, j);
  }
  WriteJsonFile(s.posed + "/perturbed.json", perturbed);
  const auto rotation_error = [&](const std::string& cameras) {
    const CommandResult r = RunNerfreg("dbarf eval-poses " + cameras + " --ground-truth " + s.data +
                                       "/transforms.json --align rotations --json");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return Json::parse(r.output.substr(r.output.find('{')))["rotation_deg_median"].get<double>();
  };
  const double before = rotation_error(s.posed + "/perturbed.json");
  // 2 deg off, 40 steps: the rate for cameras this far off (the default, 3e-4, is for the
  // sub-degree cameras dbarf poses gives, docs/poses_and_views.md "Camera refinement").
  // First the RGB loss's refinement alone (--depth-ba-rounds 0).
  const std::string refined = s.dir.File("refined.json");
  const CommandResult r = RunNerfreg("dbarf finetune " + s.posed +
                                     "/perturbed.json --schedule nerf --nerf-poses cameras "
                                     "--refine-cameras " +
                                     refined +
                                     " --steps 40 --rays 300 --sources 3 --lr-cameras 3e-3 --depth-ba-rounds 0 "
                                     "--checkpoint-every 40 --quiet --out " +
                                     s.dir.File("ft.pt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const double after = rotation_error(refined);
  EXPECT_GT(before, 1.5);
  EXPECT_LT(after, 0.75 * before) << "median rotation error " << before << " -> " << after << " deg";
  // Then the same run resumed with no more steps, and the default last stage: the cameras
  // bundle-adjusted through the finetuned renderer's depths (each view rendered again over its
  // own depth range) land closer still. 4 sources, not the default 8: 8 doubles the warps, and
  // with 8 this test ran 248 s on a busy 2-core machine, over ctest's 180 s limit. At 64 px wide,
  // half the scene's 128: the test 60 -> 27 s idle, and the stage still takes the median rotation
  // error from 0.90 to 0.32 deg (2026-11-29).
  const std::string adjusted = s.dir.File("adjusted.json");
  const CommandResult ba = RunNerfreg(
      "dbarf finetune " + s.posed + "/perturbed.json --schedule nerf --nerf-poses cameras --refine-cameras " +
      adjusted + " --steps 40 --resume --depth-ba-sources 4 --depth-ba-max-width 64 --quiet --out " +
      s.dir.File("ft.pt"));
  ASSERT_EQ(ba.exit_code, 0) << ba.output;
  const double after_ba = rotation_error(adjusted);
  EXPECT_LT(after_ba, 0.75 * after) << "median rotation error " << after << " -> " << after_ba
                                    << " deg by the depth BA";
  const Json depth_ba = ReadJsonFile(s.dir.File("ft.pt.json"))["depth_ba"];
  EXPECT_EQ(depth_ba["sources"], 4);
  EXPECT_GT(depth_ba["view_range_margin"].get<double>(), 1.0);  // the default's second render
  std::printf("median rotation error: perturbed %.3f, RGB refinement %.3f, then depth BA %.3f deg\n", before, after,
              after_ba);
  // The refined file is a posed-images file like dbarf poses' (view graph and depth range kept).
  const Json j = ReadJsonFile(refined);
  EXPECT_EQ(j["view_graph"], s.poses["view_graph"]);
  EXPECT_EQ(j["dbarf_poses"]["near"], s.poses["dbarf_poses"]["near"]);
  // Refining needs the sources placed by the cameras, and posed images written by dbarf poses.
  CommandResult bad = RunNerfreg("dbarf finetune " + s.posed + "/perturbed.json --refine-cameras " +
                                 s.dir.File("r2.json") + " --steps 1 --quiet --out " + s.dir.File("ft2.pt"));
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("--nerf-poses cameras"), std::string::npos) << bad.output;
}

TEST(DbarfTrainCli, WeightsOfAnotherKindOrMissingAreOneLineErrors) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene");
  ASSERT_EQ(RunNerfreg("render --procedural 7 --trajectory forward --views 6 --quiet --out " + data).exit_code, 0);
  {
    std::ofstream f(dir.File("junk.pt"));
    f << "not a torch archive";
  }
  CommandResult r = RunNerfreg("dbarf eval " + data + "/transforms.json --weights " + dir.File("junk.pt") + " --out " +
                               dir.File("e"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(dir.File("junk.pt")), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("e")));
  r = RunNerfreg("dbarf finetune " + data + "/transforms.json --weights " + dir.File("missing.pt") + " --out " +
                 dir.File("f.pt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("missing.pt"), std::string::npos) << r.output;
  r = RunNerfreg("dbarf pretrain " + data + "/transforms.json --resume --out " + dir.File("none.pt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("none.pt"), std::string::npos) << r.output;
}

TEST(DbarfTrainCli, AnLlffSceneTrainsLikeOurOwn) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene"), llff = dir.File("llff");
  ASSERT_EQ(RunNerfreg("render --procedural 7 --trajectory forward --views 8 --quiet --out " + data).exit_code, 0);
  CommandResult r = RunNerfreg("convert " + data + "/transforms.json --to llff --quiet --out " + llff);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::filesystem::copy(data + "/images", llff + "/images");
  r = RunNerfreg("dbarf pretrain " + llff + " --steps 2 --stage-steps 1 --rays 32 --sources 2 --quiet --out " +
                 dir.File("w.pt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json log = Json::parse("[" + [&] {
    std::ifstream in(dir.File("w.pt.log.jsonl"));
    std::string all, line;
    while (std::getline(in, line)) all += (all.empty() ? "" : ",") + line;
    return all;
  }() + "]");
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[0]["stage"], "pose");
  EXPECT_EQ(log[1]["stage"], "nerf");
  ASSERT_TRUE(log[1].contains("psnr")) << log.dump();
  EXPECT_GT(log[1]["psnr"].get<double>(), 5.0) << log.dump();
}

// The shipped weights (models/dbarf_cpu.pt) on a held-out scene (a procedural seed never used for
// training): every image posed from the pixels, the test views rendered at their estimated cameras
// well above what blending the nearest source would give.
TEST(DbarfTrainCli, ShippedWeightsRenderHeldOutViewsAtTheirEstimatedCameras) {
  const std::string weights = std::string(NERFREG_SOURCE_DIR) + "/models/dbarf_cpu.pt";
  ASSERT_TRUE(std::filesystem::exists(weights)) << weights;
  ScopedTempDir dir;
  const std::string data = dir.File("scene");
  ASSERT_EQ(RunNerfreg("render --procedural 301 --trajectory forward --views 12 --test-every 6 --quiet --out " + data)
                .exit_code,
            0);
  const CommandResult r = RunNerfreg("dbarf eval " + data + "/transforms.json --weights " + weights +
                                     " --sources 5 --quiet --out " + dir.File("eval"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json e = ReadJsonFile(dir.File("eval/eval.json"));
  EXPECT_EQ(e["posed"].get<int>(), 12);
  EXPECT_EQ(e["rendered"].get<int>(), 2);
  EXPECT_GT(e["psnr_mean"].get<double>(), 24.0) << e.dump();
}

}  // namespace
}  // namespace nerfreg
