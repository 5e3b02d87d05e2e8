// 3D Gaussian splats end to end: render --splats writes a capture per block, reg register
// registers two of them (the default method, the shipped network included) to the known
// transform, reg eval scores it, and reg apply moves the splats and cameras into the other frame
// and, with --inverse, back.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cli_test_util.h"
#include "nerfreg/data/ground_truth.h"
#include "nerfreg/data/sim3_apply.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/reg/registration_success.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

Sim3d ReadPose(const std::string& path) {
  return Sim3d::FromMatrix(JsonField(ReadJsonFile(path), path)["target_from_source"].Matrix(4, 4), 1e-3);
}

TEST(SplatsCli, TwoSplatCapturesRegisterAndApplyMovesFilesAcrossFrames) {
  ScopedTempDir dir;
  const CommandResult render = RunNerfreg(
      "render --procedural 23 --blocks 2 --views 60 --size 64 --supersample 1 --splats "
      "--quiet --out " +
      dir.File("data"));
  ASSERT_EQ(render.exit_code, 0) << render.output;
  const std::string a = dir.File("data/block_0/splats.ply"), b = dir.File("data/block_1/splats.ply");
  ASSERT_TRUE(IsSplatPly(a) && IsSplatPly(b) && IsSplatPly(dir.File("data/splats.ply")));

  const CommandResult reg = RunNerfreg("reg register " + a + " " + b + " --seed 0 --quiet --out " + dir.File("t.json"));
  ASSERT_EQ(reg.exit_code, 0) << reg.output;
  const Json t = ReadJsonFile(dir.File("t.json"));
  EXPECT_EQ(t["source_kind"], "splats");
  EXPECT_EQ(t["target_kind"], "splats");
  const Sim3d est = ReadPose(dir.File("t.json"));
  const Sim3d truth = GroundTruthFile(dir.File("data/ground_truth.json")).TargetFromSource(0, 1);
  const double rot = RotationErrorDeg(est.rotation, truth.rotation);
  const double trans = TranslationError(est.translation, truth.translation);
  EXPECT_TRUE(RegistrationSucceeded(rot, trans)) << rot << " deg, " << trans << "\n" << t.dump();
  std::printf("reg register splats (%s): %.3f deg, %.4f\n", t["method"].get<std::string>().c_str(), rot, trans);
  const CommandResult eval =
      RunNerfreg("reg eval --pair " + dir.File("t.json") + " --ground-truth " + dir.File("data/ground_truth.json"));
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  EXPECT_NE(eval.output.find("yes"), std::string::npos) << eval.output;

  // Block 0's splats and cameras moved into block 1's frame land where the truth puts them.
  ASSERT_EQ(
      RunNerfreg("reg apply " + dir.File("t.json") + " " + a + " --quiet --out " + dir.File("a_in_b.ply")).exit_code,
      0);
  const Splats s = ReadSplatPly(a), moved = ReadSplatPly(dir.File("a_in_b.ply"));
  ASSERT_EQ(moved.size(), s.size());
  double worst = 0;
  for (std::int64_t i = 0; i < s.size(); ++i) {
    const Eigen::Vector3d p = s.position.col(i).cast<double>();
    worst = std::max(worst, (moved.position.col(i).cast<double>() - truth * p).norm());
  }
  EXPECT_LT(worst, 0.05 * kObjectExtent);
  const CommandResult cams = RunNerfreg("reg apply " + dir.File("t.json") + " " + dir.File("data/block_0") +
                                        " --quiet --out " + dir.File("cams_in_b/transforms.json"));
  ASSERT_EQ(cams.exit_code, 0) << cams.output;
  const Dataset in_a = ReadTransformsJson(dir.File("data/block_0/transforms.json"));
  const Dataset in_b = ReadTransformsJson(dir.File("cams_in_b/transforms.json"));
  const Rigid3d expected = truth.TransformCamera(in_a.frames[0].cam_from_world);
  EXPECT_LT(RotationErrorDeg(in_b.frames[0].cam_from_world.rotation, expected.rotation), 5.0);

  // And back: within 1e-6 of the original file; an existing output needs --force.
  const std::string back = "reg apply " + dir.File("t.json") + " " + dir.File("a_in_b.ply") +
                           " --inverse --quiet --out " + dir.File("back.ply");
  ASSERT_EQ(RunNerfreg(back).exit_code, 0);
  const CommandResult again = RunNerfreg(back);
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.output.find("back.ply: exists; pass --force to overwrite"), std::string::npos) << again.output;
  EXPECT_EQ(RunNerfreg(back + " --force").exit_code, 0);
  const Splats returned = ReadSplatPly(dir.File("back.ply"));
  EXPECT_LT((returned.position - s.position).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((returned.rotation - s.rotation).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((returned.log_scale - s.log_scale).cwiseAbs().maxCoeff(), 1e-6);

  // register-many on the two captures: block 1 placed in block 0's frame, both merged there.
  const CommandResult many = RunNerfreg("reg register-many " + a + " " + b + " --quiet --out " + dir.File("many.json") +
                                        " --merged-splats " + dir.File("merged.ply"));
  ASSERT_EQ(many.exit_code, 0) << many.output;
  const Json m = ReadJsonFile(dir.File("many.json"));
  const Sim3d world_from_1 = Sim3d::FromMatrix(JsonField(m, "many.json")["world_from_block"][1].Matrix(4, 4), 1e-3);
  const Sim3d expected_1 = truth.Inverse();  // block 0's frame is the world
  EXPECT_TRUE(RegistrationSucceeded(RotationErrorDeg(world_from_1.rotation, expected_1.rotation),
                                    TranslationError(world_from_1.translation, expected_1.translation)))
      << m.dump();
  const Splats merged = ReadSplatPly(dir.File("merged.ply"));
  EXPECT_EQ(merged.size(), s.size() + ReadSplatPly(b).size());
  // Block 0's splats stay where they were.
  EXPECT_LT((merged.position.leftCols(s.size()) - s.position).cwiseAbs().maxCoeff(), 1e-6);
}

// Captures of two different objects: reg register does not pass its answer off as a success. It
// writes T.json with "status": "untrusted" and the reason, says so in one line on stderr and
// exits with 5 (docs/cli.md); so does register-many, which leaves the capture out; the same
// object's captures in different units register.
TEST(SplatsCli, CapturesOfDifferentObjectsAreUntrustedAndScaledCapturesRegister) {
  ScopedTempDir dir;
  for (const char* object : {"7", "3"}) {
    const CommandResult render = RunNerfreg("render --procedural " + std::string(object) +
                                            " --blocks 2 --views 60 --size 64 --supersample 1 --splats --quiet --out " +
                                            dir.File(std::string("o") + object));
    ASSERT_EQ(render.exit_code, 0) << render.output;
  }
  const CommandResult reg =
      RunNerfreg("reg register " + dir.File("o7/block_0/splats.ply") + " " + dir.File("o3/block_1/splats.ply") +
                 " --seed 0 --quiet --out " + dir.File("t.json"));
  EXPECT_EQ(reg.exit_code, 5) << reg.output;
  EXPECT_NE(reg.output.find("untrusted: confidence"), std::string::npos) << reg.output;
  const Json t = ReadJsonFile(dir.File("t.json"));
  EXPECT_EQ(t["status"], "untrusted") << t.dump();
  EXPECT_FALSE(t["status_reason"].get<std::string>().empty());
  // Registered the other way too (target onto source), and untrusted that way as well.
  ASSERT_TRUE(t["reverse"].is_object()) << t.dump();
  EXPECT_FALSE(t["reverse"]["kept"].get<bool>());
  EXPECT_EQ(t["reverse"]["other_way"]["status"], "untrusted");
  std::printf("different objects: confidence %.3f, %d agreeing; the other way %.3f\n", t["confidence"].get<double>(),
              t["agreeing_candidates"].get<int>(), t["reverse"]["other_way"]["confidence"].get<double>());

  // register-many registers the pair as reg register does: no edge, so the second capture is not
  // registered, the output says so, it stays out of the merged splats, and the command exits with 5.
  const CommandResult many =
      RunNerfreg("reg register-many " + dir.File("o7/block_0/splats.ply") + " " + dir.File("o3/block_1/splats.ply") +
                 " --seed 0 --quiet --out " + dir.File("many.json") + " --merged-splats " + dir.File("merged.ply"));
  EXPECT_EQ(many.exit_code, 5) << many.output;
  EXPECT_NE(many.output.find("untrusted: 1 of the 2 inputs"), std::string::npos) << many.output;
  const Json m = ReadJsonFile(dir.File("many.json"));
  EXPECT_EQ(m["status"], "untrusted") << m.dump();
  EXPECT_EQ(m["connected"], Json::array({true, false})) << m.dump();
  ASSERT_EQ(m["edges"].size(), 1u);
  EXPECT_EQ(m["edges"][0]["status"], "untrusted") << m.dump();
  EXPECT_FALSE(m["edges"][0]["reverse"]["kept"].get<bool>()) << "tried the other way too: " << m.dump();
  EXPECT_FALSE(m["edges"][0]["used"].get<bool>());
  EXPECT_EQ(ReadSplatPly(dir.File("merged.ply")).size(), ReadSplatPly(dir.File("o7/block_0/splats.ply")).size());

  // Object 7's first capture scaled by 2.5 (reg apply), then registered to its second capture.
  const double s = 2.5;
  const Sim3d scaled_from_source(s, Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3));
  WriteJsonFile(dir.File("scale.json"), {{"target_from_source", MatrixToJson(scaled_from_source.ToMatrix())}});
  ASSERT_EQ(RunNerfreg("reg apply " + dir.File("scale.json") + " " + dir.File("o7/block_0/splats.ply") +
                       " --quiet --out " + dir.File("scaled.ply"))
                .exit_code,
            0);
  const CommandResult scaled =
      RunNerfreg("reg register " + dir.File("scaled.ply") + " " + dir.File("o7/block_1/splats.ply") +
                 " --seed 0 --quiet --out " + dir.File("s.json"));
  ASSERT_EQ(scaled.exit_code, 0) << scaled.output;
  const Json sj = ReadJsonFile(dir.File("s.json"));
  EXPECT_EQ(sj["status"], "registered");
  const Sim3d want =
      GroundTruthFile(dir.File("o7/ground_truth.json")).TargetFromSource(0, 1) * scaled_from_source.Inverse();
  const Sim3d est = ReadPose(dir.File("s.json"));
  EXPECT_LE(RotationErrorDeg(est.rotation, want.rotation), 2.0) << sj.dump();
  EXPECT_LE(TranslationError(est.translation, want.translation), 0.02 * kObjectExtent) << sj.dump();
  EXPECT_NEAR(est.scale / want.scale, 1.0, 0.01) << sj.dump();
}

// nerfstudio trains, and `ns-export gaussian-splat` writes, in each run's own trained frame,
// p_file = s (R p_capture + t) (its dataparser_transforms.json). Two such exports of one object
// with the files beside them: reg register recovers the similarity between the captures' own
// frames (the truth), not between the trained frames; register-many merges the splats and the
// captures' cameras (--cameras) in input 0's capture frame.
TEST(SplatsCli, NerfstudioExportsRegisterAndMergeInTheirCapturesUnits) {
  ScopedTempDir dir;
  const CommandResult render =
      RunNerfreg("render --procedural 7 --blocks 2 --views 60 --size 64 --supersample 1 --splats --quiet --out " +
                 dir.File("data"));
  ASSERT_EQ(render.exit_code, 0) << render.output;
  const Sim3d truth = GroundTruthFile(dir.File("data/ground_truth.json")).TargetFromSource(0, 1);
  // Each run's trained_from_capture: nerfstudio's auto scale and orientation differ per run.
  const Sim3d trained_from_capture[2] = {
      Sim3d(0.37, Eigen::Quaterniond(Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, 2, 0).normalized())),
            Eigen::Vector3d(0.2, -0.1, 0.05)),
      Sim3d(1.9, Eigen::Quaterniond(Eigen::AngleAxisd(-2.1, Eigen::Vector3d(0, 1, 1).normalized())),
            Eigen::Vector3d(-0.3, 0.4, 0.1))};
  std::string splat[2], dataparser[2];
  for (int k = 0; k < 2; ++k) {
    const std::string run = dir.File("ns" + std::to_string(k));
    splat[k] = run + "/splat.ply";
    dataparser[k] = run + "/dataparser_transforms.json";
    std::filesystem::create_directories(run);
    WriteSplatPly(TransformSplats(ReadSplatPly(dir.File("data/block_" + std::to_string(k) + "/splats.ply")),
                                  trained_from_capture[k]),
                  splat[k]);
    WriteDataparserTransforms(trained_from_capture[k], dataparser[k]);
  }

  const CommandResult reg = RunNerfreg("reg register " + splat[0] + " " + splat[1] + " --source-dataparser " +
                                       dataparser[0] + " --target-dataparser " + dataparser[1] +
                                       " --method ransac --seed 0 --quiet --out " + dir.File("t.json"));
  ASSERT_EQ(reg.exit_code, 0) << reg.output;
  const Json t = ReadJsonFile(dir.File("t.json"));
  EXPECT_EQ(t["source_frame"]["dataparser"], dataparser[0]);
  EXPECT_EQ(t["target_frame"]["dataparser"], dataparser[1]);
  const Sim3d est = ReadPose(dir.File("t.json"));
  EXPECT_LE(RotationErrorDeg(est.rotation, truth.rotation), 2.0) << t.dump();
  EXPECT_LE(TranslationError(est.translation, truth.translation), 0.02 * kObjectExtent) << t.dump();
  EXPECT_NEAR(est.scale / truth.scale, 1.0, 0.01) << t.dump();
  std::printf("nerfstudio exports in capture units: %.3f deg, scale %.4f (truth %.4f)\n",
              RotationErrorDeg(est.rotation, truth.rotation), est.scale, truth.scale);

  const std::string many = "reg register-many " + splat[0] + " " + splat[1] + " --dataparser 0=" + dataparser[0] +
                           " --dataparser 1=" + dataparser[1] + " --quiet --out " + dir.File("many.json");
  const CommandResult merged =
      RunNerfreg(many + " --merged-splats " + dir.File("merged.ply") + " --merged-cameras " + dir.File("cams.json") +
                 " --cameras 0=" + dir.File("data/block_0") + " --cameras 1=" + dir.File("data/block_1"));
  ASSERT_EQ(merged.exit_code, 0) << merged.output;
  EXPECT_EQ(ReadJsonFile(dir.File("many.json"))["options"]["capture_from_file"].size(), 2u);
  // Input 0's splats and cameras are back in their capture's frame, input 1's moved there by the truth.
  const Splats s0 = ReadSplatPly(dir.File("data/block_0/splats.ply")), m = ReadSplatPly(dir.File("merged.ply"));
  ASSERT_EQ(m.size(), s0.size() + ReadSplatPly(splat[1]).size());
  EXPECT_LT((m.position.leftCols(s0.size()) - s0.position).cwiseAbs().maxCoeff(), 1e-4);
  const Dataset cams = ReadTransformsJson(dir.File("cams.json"));
  const Dataset c0 = ReadTransformsJson(dir.File("data/block_0/transforms.json")),
                c1 = ReadTransformsJson(dir.File("data/block_1/transforms.json"));
  ASSERT_EQ(cams.frames.size(), c0.frames.size() + c1.frames.size());
  const auto centre = [](const Frame& f) { return Eigen::Vector3d(f.cam_from_world.Inverse().translation); };
  EXPECT_LT((centre(cams.frames[0]) - centre(c0.frames[0])).norm(), 1e-6);
  double worst = 0;
  for (size_t i = 0; i < c1.frames.size(); ++i) {
    const Frame& f = cams.frames[c0.frames.size() + i];
    worst = std::max(worst, (centre(f) - truth.Inverse() * centre(c1.frames[i])).norm());
  }
  EXPECT_LT(worst, 0.02 * kObjectExtent);

  // A K that names no input, or no K: one named error.
  for (const std::string& bad : {"2=" + dataparser[0], dataparser[0]}) {
    const CommandResult r = RunNerfreg(many + " --force --dataparser " + bad);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("error: --dataparser"), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace nerfreg
