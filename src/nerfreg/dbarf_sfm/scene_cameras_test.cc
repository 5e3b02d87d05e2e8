#include "nerfreg/dbarf_sfm/scene_cameras.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

std::string RenderForwardScene(const ScopedTempDir& dir, unsigned seed) {
  RenderDatasetOptions opt;
  opt.trajectory = "forward";
  opt.views = 8;
  opt.test_every = 100;
  opt.render.supersample = 1;
  const std::string out = dir.File("scene");
  RenderDataset(ProceduralForwardScene(seed), opt, out);
  return out;
}

int CacheEntries(const std::string& dir) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) n += e.path().extension() == ".json";
  return n;
}

TEST(SceneCameras, SfmCacheGivesTheCamerasOfTheFirstEstimateAndMissesOnOtherImages) {
  ScopedTempDir dir;
  const std::string scene = RenderForwardScene(dir, 7);
  SfmSceneCamerasOptions sfm;
  sfm.cache_dir = dir.File("cache");
  DbarfSceneOptions options;
  options.estimate_cameras = SfmCameraEstimator(sfm);
  const LoadedDbarfScene first = LoadDbarfScene(scene, options);
  ASSERT_TRUE(first.estimated_here);
  ASSERT_EQ(CacheEntries(sfm.cache_dir), 1);

  // A second load reads the entry: the same cameras, graph and range, and no new entry.
  const LoadedDbarfScene second = LoadDbarfScene(scene, options);
  EXPECT_TRUE(second.estimated_here);
  EXPECT_TRUE(torch::allclose(first.scene.cam_from_world, second.scene.cam_from_world, 1e-6, 1e-6));
  EXPECT_EQ(first.scene.neighbours, second.scene.neighbours);
  EXPECT_EQ(first.scene.usable, second.scene.usable);
  EXPECT_DOUBLE_EQ(first.scene.near, second.scene.near);
  EXPECT_DOUBLE_EQ(first.scene.far, second.scene.far);
  EXPECT_EQ(CacheEntries(sfm.cache_dir), 1);

  // The entry really is what the second load used: a doctored entry changes its cameras.
  std::string entry;
  for (const auto& e : std::filesystem::directory_iterator(sfm.cache_dir)) entry = e.path().string();
  Json json = ReadJsonFile(entry);
  json["near"] = json["near"].get<double>() * 0.5;
  WriteJsonFile(entry, json);
  EXPECT_DOUBLE_EQ(LoadDbarfScene(scene, options).scene.near, first.scene.near * 0.5);

  // Other images (another size) are another key: a new entry, estimated afresh.
  DbarfSceneOptions smaller = options;
  smaller.max_width = 64;
  const LoadedDbarfScene third = LoadDbarfScene(scene, smaller);
  EXPECT_EQ(third.scene.images.size(3), 64);
  EXPECT_EQ(CacheEntries(sfm.cache_dir), 2);

  // A damaged entry is ignored (one more SfM run), never a failure or a wrong camera.
  WriteFileAtomic(entry, "{ not json");
  const LoadedDbarfScene fourth = LoadDbarfScene(scene, options);
  EXPECT_TRUE(torch::allclose(first.scene.cam_from_world, fourth.scene.cam_from_world, 1e-6, 1e-6));
  EXPECT_DOUBLE_EQ(fourth.scene.near, first.scene.near);
}

TEST(SceneCameras, EstimatedCamerasAreTheSfmsAndTheDatasetsPosesAreKeptAsGroundTruth) {
  ScopedTempDir dir;
  const std::string scene = RenderForwardScene(dir, 7);
  DbarfSceneOptions options;
  options.estimate_cameras = SfmCameraEstimator({});
  const LoadedDbarfScene loaded = LoadDbarfScene(scene, options);
  EXPECT_TRUE(loaded.estimated_here);
  ASSERT_TRUE(loaded.ground_truth.defined());
  // The SfM's frame is not the dataset's: the first posed camera is the identity there.
  EXPECT_FALSE(torch::allclose(loaded.scene.cam_from_world, loaded.ground_truth, 1e-3, 1e-3));
  EXPECT_GT(loaded.scene.far, loaded.scene.near);
  // No estimator: the same dataset is refused, naming it and the way out.
  try {
    LoadDbarfScene(scene, DbarfSceneOptions());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--scene-cameras ground-truth"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace nerfreg
