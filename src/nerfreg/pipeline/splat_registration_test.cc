// reg register on splats: two splat captures of one procedural object, each from half of the
// views and in its own random frame (render --blocks 2 --splats), register to their known
// transform by the project's success test.
#include <gtest/gtest.h>

#include "nerfreg/data/ground_truth.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/pipeline/register_blocks.h"
#include "nerfreg/reg/registration_success.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(SplatRegistration, TwoSplatCapturesOfOneObjectRegisterToTheTruth) {
  ScopedTempDir dir;
  RenderDatasetOptions ro;
  ro.views = 60;
  ro.width = ro.height = 64;
  ro.render.supersample = 1;
  ro.blocks = 2;
  ro.write_splats = true;
  RenderDataset(ProceduralObject(7), ro, dir.File("data"));
  const Sim3d truth = GroundTruthFile(dir.File("data/ground_truth.json")).TargetFromSource(0, 1);
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

}  // namespace
}  // namespace nerfreg
