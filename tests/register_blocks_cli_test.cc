// reg register end to end on two different trained blocks of one object (each in its own random
// frame): the known transform is recovered, and T.json records the options it ran with.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "cli_test_util.h"
#include "nerfreg/data/ground_truth.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/pipeline/register_blocks.h"
#include "nerfreg/reg/registration_input.h"
#include "nerfreg/reg/registration_success.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"
#include "nerfreg/util/threads.h"

namespace nerfreg {
namespace {

// Two blocks trained once for every test here (a minute on 2 cores), with splats of the same
// renders (render --splats) for the mixed inputs. ctest runs each test in a process of its own, so
// they are kept beside the binary, keyed by its size and time: trained once per build of nerfreg,
// not once per test. They are made where they stay (a checkpoint records its dataset's path) under
// an exclusive lock, so a test started beside the one making them waits for the whole set; each
// test's outputs go to its own folder.
class RegisterBlocksCli : public ::testing::Test {
 protected:
  static void MakeSharedBlocks(const std::string& dir) {
    namespace fs = std::filesystem;
    if (fs::exists(dir + "/complete")) return;
    fs::remove_all(dir);  // a set a killed test left half made
    ASSERT_EQ(RunNerfreg("render --procedural 7 --blocks 2 --views 60 --size 64 --supersample 1 --test-every 12 "
                         "--splats --quiet --out " +
                         dir + "/data")
                  .exit_code,
              0);
    for (int k = 0; k < 2; ++k) {
      const std::string b = std::to_string(k);
      ASSERT_EQ(RunNerfreg("nerf train " + dir + "/data/block_" + b + " --out " + dir + "/b" + b +
                           ".ckpt --iters 400 --samples 8192 --quiet")
                    .exit_code,
                0);
    }
    WriteJsonFile(dir + "/complete", Json::object());
  }
  static std::string SharedBlocks() {
    namespace fs = std::filesystem;
    const fs::path binary(NERFREG_BINARY);
    const fs::path root = binary.parent_path() / "test_cache";
    // v2: the layout of the set; a change to how it is made must change it too.
    const std::string key = "register_blocks_v2_" + std::to_string(fs::file_size(binary)) + "_" +
                            std::to_string(fs::last_write_time(binary).time_since_epoch().count());
    fs::create_directories(root);
    const int lock = ::open((root / "register_blocks.lock").c_str(), O_CREAT | O_RDWR, 0644);
    if (lock >= 0) ::flock(lock, LOCK_EX);  // released when the process exits, if not before
    std::error_code ignored;
    for (const auto& old : fs::directory_iterator(root)) {  // blocks of earlier builds
      const std::string name = old.path().filename().string();
      if (name.rfind("register_blocks_", 0) == 0 && name != key) fs::remove_all(old.path(), ignored);
    }
    MakeSharedBlocks((root / key).string());
    if (lock >= 0) ::close(lock);
    return (root / key).string();
  }
  static void SetUpTestSuite() {
    dir_ = new ScopedTempDir();
    const std::string shared = SharedBlocks();
    for (const char* name : {"data", "b0.ckpt", "b1.ckpt"}) {
      std::filesystem::create_symlink(shared + "/" + name, File(name));
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string File(const std::string& name) { return dir_->File(name); }
  // reg register SOURCE TARGET (default method and refinement) and its error against the truth.
  static void ExpectRegisters(const std::string& source, const std::string& target, const std::string& out,
                              const std::string& label) {
    const CommandResult reg = RunNerfreg("reg register " + source + " " + target + " --seed 0 --quiet --out " + out);
    ASSERT_EQ(reg.exit_code, 0) << reg.output;
    const Json t = ReadJsonFile(out);
    const Sim3d est = Sim3d::FromMatrix(JsonField(t, out)["target_from_source"].Matrix(4, 4), 1e-3);
    const Sim3d truth = GroundTruthFile(File("data/ground_truth.json")).TargetFromSource(0, 1);
    const double rot = RotationErrorDeg(est.rotation, truth.rotation);
    const double trans = TranslationError(est.translation, truth.translation);
    EXPECT_TRUE(RegistrationSucceeded(rot, trans)) << label << ": " << rot << " deg, " << trans << "\n" << t.dump();
    std::printf("%s (%s): %.3f deg, %.4f, confidence %.2f\n", label.c_str(), t["method"].get<std::string>().c_str(),
                rot, trans, t["confidence"].get<double>());
  }
  static ScopedTempDir* dir_;
};

ScopedTempDir* RegisterBlocksCli::dir_ = nullptr;

TEST_F(RegisterBlocksCli, TwoTrainedBlocksOfOneObjectRegisterAndTheOptionsRoundTrip) {
  ScopedTempDir& dir = *dir_;
  // The default method (auto: dreg, FPFH + RANSAC on the grids and on the occupied points, the
  // candidate whose fields agree best on common samples kept): RANSAC alone lands 4-67 deg off on
  // blocks this small, depending on the run.
  const std::string args = dir.File("b0.ckpt") + " " + dir.File("b1.ckpt") + " --seed 0 --quiet --out ";
  const CommandResult reg = RunNerfreg("reg register " + args + dir.File("t.json"));
  ASSERT_EQ(reg.exit_code, 0) << reg.output;
  const Json t = ReadJsonFile(dir.File("t.json"));
  const Sim3d est = Sim3d::FromMatrix(JsonField(t, "t.json")["target_from_source"].Matrix(4, 4), 1e-3);
  const Sim3d truth = GroundTruthFile(dir.File("data/ground_truth.json")).TargetFromSource(0, 1);
  // The success test of reg eval.
  EXPECT_TRUE(RegistrationSucceeded(RotationErrorDeg(est.rotation, truth.rotation),
                                    TranslationError(est.translation, truth.translation)))
      << t.dump();
  EXPECT_GT(t["confidence"].get<double>(), 0.3) << t.dump();
  EXPECT_GE(t["method_score"].get<double>(), 0.0) << t.dump();

  // The options recorded are the options given, and RegisterBlocks run in-process on those
  // recorded options alone (no flags) gives the same pose.
  const BlockRegistrationOptions o = BlockRegistrationOptions::FromJson(t["options"], "t.json");
  EXPECT_EQ(o.method, RegistrationMethod::kAuto);
  EXPECT_EQ(o.refine, RegistrationRefinement::kField);
  EXPECT_EQ(o.seed, 0u);
  EXPECT_EQ(o.ToJson(), t["options"]);
  ASSERT_NO_THROW(o.Check());
  // With the binary's thread count (exe/threads.cc).
  const int test_threads = torch::get_num_threads();
  torch::set_num_threads(ThreadCount(std::thread::hardware_concurrency(), std::getenv("OMP_NUM_THREADS")));
  const auto source = LoadRegistrationInput(dir.File("b0.ckpt"), o.splats, o.device);
  const auto target = LoadRegistrationInput(dir.File("b1.ckpt"), o.splats, o.device);
  std::unique_ptr<DregNet> net;
  if (o.UsesNetwork()) net = std::make_unique<DregNet>(LoadCheckedDregNet(o));
  const RegistrationResult again = RegisterBlocks(*source, *target, o, net.get());
  torch::set_num_threads(test_threads);
  // Not to the last bit: in another process the reductions round differently (the same binary
  // run twice agrees to 1e-15, checked below), and the candidates here agree with the fields
  // within ~1e-3, so that rounding can change which one is kept (seen: 0.10 and 0.24 deg apart
  // under ctest, once 3.7 deg, when two candidates ended that far apart). So the in-process pose
  // must be one of the binary's candidates, kept or not.
  std::vector<Sim3d> candidates = {est};
  for (const Json& c : t["not_chosen"]) {
    candidates.push_back(Sim3d::FromMatrix(JsonField(c, "t.json")["target_from_source"].Matrix(4, 4), 1e-3));
  }
  double closest_deg = 1e9, closest_translation = 1e9;
  for (const Sim3d& c : candidates) {
    const double deg = RotationErrorDeg(again.target_from_source.rotation, c.rotation);
    if (deg < closest_deg)
      closest_deg = deg, closest_translation = (again.target_from_source.translation - c.translation).norm();
  }
  EXPECT_LT(closest_deg, 0.5) << t.dump();
  EXPECT_LT(closest_translation, 0.01 * kObjectExtent) << t.dump();
  EXPECT_NEAR(again.confidence, t["confidence"].get<double>(), 0.01);

  // The binary run again with the same flags: the same pose up to rounding.
  ASSERT_EQ(RunNerfreg("reg register " + args + dir.File("again.json")).exit_code, 0);
  const Json cli_again = ReadJsonFile(dir.File("again.json"));
  const Sim3d second = Sim3d::FromMatrix(JsonField(cli_again, "again.json")["target_from_source"].Matrix(4, 4), 1e-3);
  // Entry-wise, not by angle: RotationErrorDeg is 2 acos(|q1 . q2|), 1.7e-6 deg at one ulp below 1,
  // so a 1e-6 deg bound held only for bit-identical quaternions (it failed once under ctest, 2.4e-6).
  EXPECT_LT((second.rotation.toRotationMatrix() - est.rotation.toRotationMatrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((second.translation - est.translation).norm(), 1e-9);
}

// A block and a splat capture of the other half of the views, either way round; and a block
// exported as splats (nerf export --splats) against the other block.
TEST_F(RegisterBlocksCli, BlocksAndSplatsRegisterMixed) {
  ExpectRegisters(File("b0.ckpt"), File("data/block_1/splats.ply"), File("mixed.json"), "block -> splats");
  EXPECT_EQ(ReadJsonFile(File("mixed.json"))["target_kind"], "splats");
  ExpectRegisters(File("data/block_0/splats.ply"), File("b1.ckpt"), File("mixed2.json"), "splats -> block");
  const CommandResult exported =
      RunNerfreg("nerf export " + File("b0.ckpt") + " --splats " + File("b0.ply") + " --quiet");
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  ASSERT_TRUE(IsSplatPly(File("b0.ply")));
  ExpectRegisters(File("b0.ply"), File("b1.ckpt"), File("exported.json"), "exported splats -> block");
}

// A block moved by reg apply (its frame, not its field) is where the truth puts it: registering it
// to the other block's own frame gives the identity.
TEST_F(RegisterBlocksCli, AppliedBlockLandsInTheOtherFrame) {
  WriteJsonFile(File("truth.json"),
                {{"target_from_source",
                  MatrixToJson(GroundTruthFile(File("data/ground_truth.json")).TargetFromSource(0, 1).ToMatrix())}});
  const CommandResult apply =
      RunNerfreg("reg apply " + File("truth.json") + " " + File("b0.ckpt") + " --quiet --out " + File("b0_in_b1.ckpt"));
  ASSERT_EQ(apply.exit_code, 0) << apply.output;
  const CommandResult reg = RunNerfreg("reg register " + File("b0_in_b1.ckpt") + " " + File("b1.ckpt") +
                                       " --method ransac --seed 0 --quiet --out " + File("identity.json"));
  ASSERT_EQ(reg.exit_code, 0) << reg.output;
  const Sim3d est = Sim3d::FromMatrix(
      JsonField(ReadJsonFile(File("identity.json")), "identity.json")["target_from_source"].Matrix(4, 4), 1e-3);
  EXPECT_TRUE(
      RegistrationSucceeded(RotationErrorDeg(est.rotation, Eigen::Quaterniond::Identity()), est.translation.norm()))
      << est.ToMatrix();
  // Training refuses to resume a moved block.
  const CommandResult resume = RunNerfreg("nerf train " + File("data/block_0") + " --out " + File("b0_in_b1.ckpt") +
                                          " --resume --iters 500 --quiet");
  EXPECT_EQ(resume.exit_code, 2) << resume.output;
  EXPECT_NE(resume.output.find("b0_in_b1.ckpt: world_from_field: expected a block in the frame it was trained in"),
            std::string::npos)
      << resume.output;
}

// register-many --merged-cameras: every block's cameras in block 0's frame, in one transforms.json
// that reads back; block 0's as they were, block 1's where the truth puts them (the registration's
// error at their distance), and each image path absolute so the file works from anywhere.
TEST_F(RegisterBlocksCli, RegisterManyWritesEveryCameraInOneFrame) {
  const std::string out = File("many_cams.json");
  const CommandResult many = RunNerfreg("reg register-many " + File("b0.ckpt") + " " + File("b1.ckpt") +
                                        " --seed 0 --quiet --out " + File("many.json") + " --merged-cameras " + out);
  ASSERT_EQ(many.exit_code, 0) << many.output;
  const Dataset merged = ReadTransformsJson(out);
  const Dataset in0 = ReadTransformsJson(File("data/block_0/transforms.json"));
  const Dataset in1 = ReadTransformsJson(File("data/block_1/transforms.json"));
  ASSERT_EQ(merged.frames.size(), in0.frames.size() + in1.frames.size());
  const Json j = ReadJsonFile(out);
  const Sim3d block0_from_block1 = GroundTruthFile(File("data/ground_truth.json")).TargetFromSource(1, 0);
  for (size_t i = 0; i < merged.frames.size(); ++i) {
    const Frame& f = merged.frames[i];
    EXPECT_EQ(f.file_path.front(), '/') << f.file_path;
    EXPECT_TRUE(FileExists(f.file_path)) << f.file_path;
    const int block = j["frames"][i]["block"].get<int>();
    const Dataset& own = block == 0 ? in0 : in1;
    const Frame* mine = nullptr;
    for (const Frame& g : own.frames)
      if (g.name == std::filesystem::path(f.file_path).filename().string()) mine = &g;
    ASSERT_NE(mine, nullptr) << f.file_path;
    const Rigid3d expected =
        block == 0 ? mine->cam_from_world : block0_from_block1.TransformCamera(mine->cam_from_world);
    EXPECT_LT(RotationErrorDeg(f.cam_from_world.rotation, expected.rotation), 5.0) << f.file_path;
    EXPECT_LT((f.cam_from_world.Inverse().translation - expected.Inverse().translation).norm(), 0.1 * kObjectExtent)
        << f.file_path;
    if (block == 0) EXPECT_LT((f.cam_from_world.Inverse().translation - expected.Inverse().translation).norm(), 1e-6);
  }
  // An existing output needs --force; nothing is written.
  const CommandResult again = RunNerfreg("reg register-many " + File("b0.ckpt") + " " + File("b1.ckpt") +
                                         " --quiet --out " + File("many2.json") + " --merged-cameras " + out);
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_FALSE(FileExists(File("many2.json")));
}

}  // namespace
}  // namespace nerfreg
