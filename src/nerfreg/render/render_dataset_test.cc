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

// An LLFF-like set: each view's depth range spans a near / far ratio like LLFF's, and rendering
// again gives the same files byte for byte.
TEST(RenderDataset, LlffScenesHaveLayeredDepthAndRenderDeterministically) {
  ScopedTempDir dir;
  RenderDatasetOptions opt;
  opt.trajectory = "llff";
  opt.views = 6;
  opt.width = 48;
  opt.trajectory_seed = 4;
  opt.render.supersample = 1;
  const TriangleMesh scene = ProceduralLayeredScene(4);
  RenderDataset(scene, opt, dir.File("a"));
  RenderDataset(scene, opt, dir.File("b"));
  const Dataset d = ReadTransformsJson(dir.File("a/transforms.json"));
  ASSERT_EQ(d.frames.size(), 6u);
  CheckImagesMatchCameras(d);
  for (const auto& f : d.frames) {
    EXPECT_EQ(f.camera.height, 36);
    EXPECT_GT(f.far / f.near, 8.0) << f.name;     // 12 here; the look-at scenes about 2.5
    EXPECT_NEAR(f.far, 1.1 * 16, 1.0) << f.name;  // the backdrop, 16 units ahead
    // Nearly parallel axes: the optical axis within a few degrees of +y.
    EXPECT_GT((f.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ()).y(), std::cos(4 * M_PI / 180));
  }
  for (const std::string file : {"transforms.json", "images/r_000.png", "images/r_005.png"})
    EXPECT_EQ(ReadFileToString(dir.File("a/" + file)), ReadFileToString(dir.File("b/" + file))) << file;
  // Another seed's path: other cameras.
  opt.trajectory_seed = 5;
  RenderDataset(scene, opt, dir.File("c"));
  EXPECT_NE(ReadFileToString(dir.File("a/transforms.json")), ReadFileToString(dir.File("c/transforms.json")));
}

// A room walk: no view starts inside or against a surface (the furniture keeps clear of the walk),
// and every view sees the room (depths within its diagonal).
TEST(RenderDataset, RoomWalksStayClearOfTheFurniture) {
  ScopedTempDir dir;
  RenderDatasetOptions opt;
  opt.trajectory = "room";
  opt.views = 12;
  opt.width = 32;
  opt.render.supersample = 1;
  for (unsigned seed : {1u, 2u, 3u}) {
    opt.trajectory_seed = seed;
    const std::string out = dir.File("room" + std::to_string(seed));
    RenderDataset(ProceduralRoom(seed), opt, out);
    const Dataset d = ReadTransformsJson(out + "/transforms.json");
    ASSERT_EQ(d.frames.size(), 12u);
    for (const auto& f : d.frames) {
      EXPECT_GT(f.near, 0.9 * 0.3) << seed << " " << f.name;
      EXPECT_LT(f.far, 1.1 * std::sqrt(6.0 * 6.0 + 5.0 * 5.0 + 2.6 * 2.6)) << seed << " " << f.name;
    }
  }
  EXPECT_THROW(ProceduralRoom(1, SceneMaterial::kRepetitive), InputError);
}

}  // namespace
}  // namespace nerfreg
