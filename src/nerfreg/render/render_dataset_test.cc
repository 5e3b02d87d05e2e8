#include "nerfreg/render/render_dataset.h"

#include <gtest/gtest.h>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/geometry/conventions.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(RenderDataset, BlocksMappedBackByTheGroundTruthEqualTheWorldCameras) {
  ScopedTempDir dir;
  TriangleMesh mesh = LoadMesh("/usr/share/assimp/models/OBJ/spider.obj");
  NormalizeMesh(&mesh);
  RenderDatasetOptions opt;
  opt.views = 24;
  opt.width = 32;
  opt.blocks = 2;
  opt.test_every = 5;
  opt.seed = 3;
  opt.render.supersample = 1;
  const std::string out = dir.File("spider");
  const auto summary = RenderDataset(mesh, opt, out);
  EXPECT_EQ(summary.views, 24);
  const Dataset world = ReadTransformsJson(out + "/transforms.json");
  ASSERT_EQ(world.frames.size(), 24u);
  CheckImagesMatchCameras(world);
  const Json gt = ReadJsonFile(out + "/ground_truth.json");
  ASSERT_EQ(gt["blocks"].size(), 2u);
  size_t total = 0;
  for (int k = 0; k < 2; ++k) {
    const Dataset block = ReadTransformsJson(out + "/block_" + std::to_string(k) + "/transforms.json");
    CheckImagesMatchCameras(block);
    total += block.frames.size();
    const Sim3d block_from_world = Sim3d::FromMatrix(JsonField(gt, "gt")["blocks"][k]["block_from_world"].Matrix(4, 4));
    // Identity would make this test pass vacuously: the frames must really differ.
    EXPECT_GT(RotationErrorDeg(block_from_world.rotation, Eigen::Quaterniond::Identity()) +
                  block_from_world.translation.norm(),
              1e-3);
    int tests = 0;
    for (size_t j = 0; j < block.frames.size(); ++j) {
      const Frame& f = block.frames[j];
      const Frame* w = nullptr;
      for (const auto& g : world.frames)
        if (g.name == f.name) w = &g;
      ASSERT_NE(w, nullptr) << f.name;
      const Rigid3d back = block_from_world.Inverse().TransformCamera(f.cam_from_world);
      EXPECT_LT((back.ToMatrix() - w->cam_from_world.ToMatrix()).cwiseAbs().maxCoeff(), 1e-9) << f.name;
      EXPECT_EQ(f.split, j % 5 == 0 ? "test" : "train");
      tests += f.split == "test";
    }
    EXPECT_GT(tests, 0);
  }
  EXPECT_EQ(total, 24u);
  // Existing output: refused without force, replaced with it; no temp folders left behind.
  EXPECT_THROW(RenderDataset(mesh, opt, out), InputError);
  opt.force = true;
  opt.blocks = 1;
  RenderDataset(mesh, opt, out);
  EXPECT_FALSE(FileExists(out + "/ground_truth.json"));
  int entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
}

TEST(RenderDataset, ForwardScenesRecordDepthBounds) {
  ScopedTempDir dir;
  RenderDatasetOptions opt;
  opt.trajectory = "forward";
  opt.views = 4;
  opt.width = 32;
  opt.render.supersample = 1;
  RenderDataset(ProceduralForwardScene(1), opt, dir.File("fwd"));
  const Dataset d = ReadTransformsJson(dir.File("fwd/transforms.json"));
  for (const auto& f : d.frames) {
    EXPECT_GT(f.near, 0.5);
    EXPECT_LT(f.near, f.far);
    EXPECT_LT(f.far, 10.0);  // the backdrop is 6 units away
    EXPECT_EQ(f.camera.height, 24);
  }
}

}  // namespace
}  // namespace nerfreg
