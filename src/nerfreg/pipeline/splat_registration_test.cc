// reg register on splats: two splat captures of one procedural object, each from half of the
// views and in its own random frame (render --blocks 2 --splats), register to their known
// transform by the project's success test.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include "nerfreg/data/ground_truth.h"
#include "nerfreg/data/sim3_apply.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/pipeline/register_blocks.h"
#include "nerfreg/pipeline/register_many_blocks.h"
#include "nerfreg/reg/registration_success.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Object 7 rendered from 60 views of 64 x 64 in two blocks, each with its splat capture
// (DIR/data/block_{0,1}/splats.ply); returns block 1 from block 0, the truth.
Sim3d RenderTwoSplatCaptures(const ScopedTempDir& dir) {
  RenderDatasetOptions ro;
  ro.views = 60;
  ro.width = ro.height = 64;
  ro.render.supersample = 1;
  ro.blocks = 2;
  ro.write_splats = true;
  RenderDataset(ProceduralObject(7), ro, dir.File("data"));
  return GroundTruthFile(dir.File("data/ground_truth.json")).TargetFromSource(0, 1);
}

TEST(SplatRegistration, TwoSplatCapturesOfOneObjectRegisterToTheTruth) {
  ScopedTempDir dir;
  const Sim3d truth = RenderTwoSplatCaptures(dir);
  const SplatFieldOptions so;
  SplatInput source(ReadSplatPly(dir.File("data/block_0/splats.ply")), so);
  SplatInput target(ReadSplatPly(dir.File("data/block_1/splats.ply")), so);
  ASSERT_GT(source.field().size(), 1000);
  BlockRegistrationOptions o;
  o.method = RegistrationMethod::kRansac;
  o.refine = RegistrationRefinement::kField;
  const BlockRegistrationResult r = RegisterBlocks(source, target, o, nullptr);
  const double rot = RotationErrorDeg(r.target_from_source.rotation, truth.rotation);
  const double trans = TranslationError(r.target_from_source.translation, truth.translation);
  EXPECT_TRUE(RegistrationSucceeded(rot, trans)) << rot << " deg, " << trans << "\n" << r.ToJson().dump();
  EXPECT_EQ(r.source_kind, "splats");
  EXPECT_EQ(r.ToJson()["target_kind"], "splats");
  EXPECT_GT(r.confidence, 0.5) << r.ToJson().dump();
  std::printf("splats ransac+icp+block+field: %.3f deg, %.4f (%.2f %% of the extent), confidence %.2f\n", rot, trans,
              100 * trans / kObjectExtent, r.confidence);
}

// Captures of one object in different units (one capture's splats scaled by 0.4 and by 2.5, and
// turned and shifted too): the default (ScaleMode::kFree) recovers the similarity between them, its
// scale within 1 %; kFixed, rigid, returns scale 1 and misses.
TEST(SplatRegistration, KnownSimilarityIsRecoveredBetweenCapturesOfDifferentScales) {
  ScopedTempDir dir;
  const Sim3d truth = RenderTwoSplatCaptures(dir);
  const Splats source_splats = ReadSplatPly(dir.File("data/block_0/splats.ply"));
  const SplatFieldOptions so;
  SplatInput target(ReadSplatPly(dir.File("data/block_1/splats.ply")), so);
  BlockRegistrationOptions o;
  o.method = RegistrationMethod::kRansac;
  o.refine = RegistrationRefinement::kIcp;
  for (const double scale : {0.4, 2.5}) {
    const Sim3d scaled_from_source(scale,
                                   Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized())),
                                   Eigen::Vector3d(3, -1, 2) * scale);
    SplatInput source(TransformSplats(source_splats, scaled_from_source), so);
    const Sim3d want = truth * scaled_from_source.Inverse();
    o.scale = ScaleMode::kFree;
    const BlockRegistrationResult r = RegisterBlocks(source, target, o, nullptr);
    const double rot = RotationErrorDeg(r.target_from_source.rotation, want.rotation);
    const double trans = TranslationError(r.target_from_source.translation, want.translation);
    const double scale_error = std::abs(r.target_from_source.scale / want.scale - 1);
    EXPECT_LE(rot, 2.0) << "scale " << scale << "\n" << r.ToJson().dump();
    EXPECT_LE(trans / kObjectExtent, 0.02) << "scale " << scale << "\n" << r.ToJson().dump();
    EXPECT_LE(scale_error, 0.01) << "scale " << scale << "\n" << r.ToJson().dump();
    EXPECT_EQ(r.status, "registered") << r.ToJson().dump();
    EXPECT_TRUE(r.ToJson()["normalization"]["source"].is_object());
    const std::string summary = RegistrationSummary(r, "T.json");
    EXPECT_EQ(summary.rfind("registered  ransac+icp (ransac, scale free)", 0), 0u) << summary;
    EXPECT_NE(summary.find(fmt::format("scale       {:.4f}", r.target_from_source.scale)), std::string::npos)
        << summary;
    std::printf("scale %.1f, free: %.3f deg, %.4f of the extent, scale error %.4f %%, confidence %.2f\n", scale, rot,
                trans / kObjectExtent, 100 * scale_error, r.confidence);
    if (scale == 2.5) {
      o.scale = ScaleMode::kFixed;
      const BlockRegistrationResult rigid = RegisterBlocks(source, target, o, nullptr);
      EXPECT_EQ(rigid.target_from_source.scale, 1.0);
      EXPECT_TRUE(rigid.ToJson()["normalization"].is_null());
      std::printf("scale %.1f, fixed: %.3f deg, confidence %.2f\n", scale,
                  RotationErrorDeg(rigid.target_from_source.rotation, want.rotation), rigid.confidence);
    }
  }
}

// The summary says when the kept pose is the other way's, inverted, and how the first way ended.
TEST(SplatRegistration, TheSummarySaysWhenThePoseWasRegisteredTheOtherWay) {
  BlockRegistrationResult forward;
  forward.method = "dreg+icp+block+field+polish";
  forward.status = "untrusted";
  forward.status_reason = "confidence 0.43 < 0.60";
  forward.confidence = 0.43;
  BlockRegistrationResult back = forward;
  back.method = "ransac-grid+icp+block+field+polish";
  back.status = "registered";
  back.status_reason.clear();
  back.confidence = 0.63;
  back.target_from_source = Sim3d(2.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0));
  back.candidates = {back};
  const BlockRegistrationResult r = RegisterEitherWay([&](bool reversed) { return reversed ? back : forward; }, true);
  const std::string summary = RegistrationSummary(r, "T.json");
  EXPECT_EQ(summary.rfind("registered  ransac-grid+icp+block+field+polish+reverse", 0), 0u) << summary;
  EXPECT_NE(summary.find("other way   source -> target was untrusted (confidence 0.43): the target onto the source, "
                         "inverted"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("scale       0.5000"), std::string::npos) << summary;
  EXPECT_EQ(RegistrationSummary(forward, "T.json").find("other way"), std::string::npos);
}

// register-many on three captures in three units: object 7's two captures (block 1's scaled by
// 0.4) and block 0's again, scaled by 2.5, turned and shifted (a loop of one real registration
// and two of one capture's copies). The Sim(3) pose graph brings each into block 0's frame, its
// scale within 1 %; the rigid graph (--scale fixed) places neither, and says so (each pair
// untrusted, the inputs not connected).
TEST(SplatRegistration, RegisterManyBringsCapturesAtThreeScalesIntoOneFrame) {
  ScopedTempDir dir;
  const Sim3d block0_from_block1 = RenderTwoSplatCaptures(dir).Inverse();
  const std::vector<double> scales = {1.0, 0.4, 2.5};
  const std::vector<int> capture = {0, 1, 0};
  std::vector<std::string> paths;
  std::vector<Sim3d> want;                // block 0 from input k
  std::vector<Eigen::Vector3d> centroid;  // of input k's splats, its frame
  for (int k = 0; k < 3; ++k) {
    const Sim3d scaled_from_block(
        scales[k], Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * k, Eigen::Vector3d(1, -2, 0.5).normalized())),
        Eigen::Vector3d(1, -1, 2) * k);
    paths.push_back(dir.File("s" + std::to_string(k) + ".ply"));
    const Splats splats = TransformSplats(
        ReadSplatPly(dir.File("data/block_" + std::to_string(capture[k]) + "/splats.ply")), scaled_from_block);
    WriteSplatPly(splats, paths.back());
    centroid.push_back(splats.position.cast<double>().rowwise().mean());
    want.push_back((capture[k] == 0 ? Sim3d() : block0_from_block1) * scaled_from_block.Inverse());
  }
  ManyBlockRegistrationOptions o;
  o.pair.refine = RegistrationRefinement::kIcp;
  o.pair.max_points = 1000;  // FPFH + RANSAC's cost, 6 pairs in all
  const ManyBlockRegistrationResult r = RegisterManyBlocks(paths, o, nullptr);
  ASSERT_EQ(r.world_from_block.size(), 3u);
  // Without the field refinement, the pair of the two scaled copies of different captures agrees too
  // little to be trusted (0.13); two edges still link every input.
  EXPECT_GE(r.used_edges, 2) << r.json.dump();
  EXPECT_EQ(r.unconnected, 0) << r.json.dump();
  EXPECT_EQ(r.json["status"], "registered");
  for (int k = 1; k < 3; ++k) {
    const Sim3d& est = r.world_from_block[k];
    const double rot = RotationErrorDeg(est.rotation, want[k].rotation);
    // Where the object lands (the frames' origins lie far from it, where a small turn moves much).
    const double trans = (est * centroid[k] - want[k] * centroid[k]).norm();
    const double scale_error = std::abs(est.scale / want[k].scale - 1);
    EXPECT_LE(rot, 2.0) << k << "\n" << r.json.dump();
    EXPECT_LE(trans / kObjectExtent, 0.02) << k << "\n" << r.json.dump();
    EXPECT_LE(scale_error, 0.01) << k << "\n" << r.json.dump();
    std::printf("register-many, input %d at scale %.1f: %.3f deg, %.4f of the extent, scale error %.3f %%\n", k,
                scales[k], rot, trans / kObjectExtent, 100 * scale_error);
  }
  std::printf("register-many: %.1f s\n", r.json["seconds"].get<double>());
  o.pair.scale = ScaleMode::kFixed;
  const ManyBlockRegistrationResult rigid = RegisterManyBlocks(paths, o, nullptr);
  int placed = 0;
  for (int k = 1; k < 3; ++k) {
    const Sim3d& est = rigid.world_from_block[k];
    EXPECT_EQ(est.scale, 1.0);
    placed += RegistrationSucceeded(RotationErrorDeg(est.rotation, want[k].rotation),
                                    (est * centroid[k] - want[k] * centroid[k]).norm());
  }
  EXPECT_EQ(placed, 0) << rigid.json.dump();
  EXPECT_EQ(rigid.unconnected, 2) << rigid.json.dump();
  EXPECT_EQ(rigid.json["status"], "untrusted");
}

}  // namespace
}  // namespace nerfreg
