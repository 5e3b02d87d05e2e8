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

}  // namespace
}  // namespace nerfreg
