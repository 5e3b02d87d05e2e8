// `nerfreg render` end to end, as a user runs it: the dataset's blocks, mapped back by the
// ground truth, have exactly the world cameras.
#include <gtest/gtest.h>

#include "cli_test_util.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(RenderCli, AssimpMeshIntoTwoBlocksWithGroundTruth) {
  ScopedTempDir dir;
  const std::string out = dir.File("d");
  const CommandResult r = RunNerfreg(
      "render --mesh /usr/share/assimp/models/OBJ/spider.obj --blocks 2 --size 24 "
      "--views 40 --supersample 1 --seed 11 --quiet --out " +
      out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Dataset world = ReadTransformsJson(out + "/transforms.json");
  const Json gt = ReadJsonFile(out + "/ground_truth.json");
  size_t seen = 0;
  for (int k = 0; k < 2; ++k) {
    const Dataset block = ReadTransformsJson(out + "/block_" + std::to_string(k) + "/transforms.json");
    CheckImagesMatchCameras(block);
    const Sim3d block_from_world = Sim3d::FromMatrix(JsonField(gt, "gt")["blocks"][k]["block_from_world"].Matrix(4, 4));
    for (const auto& f : block.frames) {
      for (const auto& w : world.frames) {
        if (w.name != f.name) continue;
        ++seen;
        const Rigid3d back = block_from_world.Inverse().TransformCamera(f.cam_from_world);
        EXPECT_LT((back.ToMatrix() - w.cam_from_world.ToMatrix()).cwiseAbs().maxCoeff(), 1e-9) << f.name;
      }
    }
  }
  EXPECT_EQ(seen, 40u);
}

}  // namespace
}  // namespace nerfreg

namespace nerfreg {
namespace {

// LibTorch's matrix products must reach OpenBLAS, not ATLAS's libf77blas (which Debian's Ceres
// links): the binary names libblas.so.3 before libf77blas.so.3, so the loader binds sgemm_ to it.
TEST(Binary, OpenBlasIsBoundBeforeAtlas) {
  const CommandResult r = RunShell("readelf -d " + std::string(NERFREG_BINARY) + " | grep NEEDED");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const size_t blas = r.output.find("[libblas.so.3]");
  ASSERT_NE(blas, std::string::npos) << r.output;
  const size_t atlas = r.output.find("[libf77blas.so.3]");
  if (atlas != std::string::npos) EXPECT_LT(blas, atlas) << r.output;
}

// The threading environment (docs/threads.md) is in place when libgomp reads it: started without
// the variables, libgomp's own report (OMP_DISPLAY_ENV, printed by its initialiser) comes once and
// shows passive waiting (no spinning: GOMP_SPINCOUNT 0, where the default is 300000). A user's own
// value is kept.
TEST(Binary, OpenMpWaitsPassivelyAndTheLibrariesInitialiseOnceUnlessTheUserSaysOtherwise) {
  const std::string binary = NERFREG_BINARY;
  const CommandResult unset =
      RunShell("env -u OMP_WAIT_POLICY -u OPENBLAS_NUM_THREADS -u NERFREG_ENV_SET OMP_DISPLAY_ENV=verbose " + binary +
               " --help 2>&1");
  ASSERT_EQ(unset.exit_code, 0) << unset.output;
  const size_t first = unset.output.find("GOMP_SPINCOUNT = ");
  ASSERT_NE(first, std::string::npos) << unset.output;
  EXPECT_EQ(unset.output.find("GOMP_SPINCOUNT = ", first + 1), std::string::npos) << unset.output;
  EXPECT_NE(unset.output.find("GOMP_SPINCOUNT = '0'"), std::string::npos) << unset.output;
  const CommandResult user =
      RunShell("env -u NERFREG_ENV_SET OMP_WAIT_POLICY=ACTIVE OMP_DISPLAY_ENV=verbose " + binary + " --help 2>&1");
  ASSERT_EQ(user.exit_code, 0) << user.output;
  EXPECT_NE(user.output.find("OMP_WAIT_POLICY = 'ACTIVE'"), std::string::npos) << user.output;
  EXPECT_EQ(user.output.find("GOMP_SPINCOUNT = '0'"), std::string::npos) << user.output;
}

}  // namespace
}  // namespace nerfreg
