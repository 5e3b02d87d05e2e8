#include "nerfreg/dbarf_data/dbarf_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <tuple>
#include <utility>

#include "nerfreg/data/convert.h"
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

TEST(DbarfScene, SfmCacheGivesTheCamerasOfTheFirstEstimateAndMissesOnOtherImages) {
  ScopedTempDir dir;
  const std::string scene = RenderForwardScene(dir, 7);
  DbarfSceneOptions options;
  options.sfm_cache_dir = dir.File("cache");
  const LoadedDbarfScene first = LoadDbarfScene(scene, options);
  ASSERT_TRUE(first.estimated_here);
  ASSERT_EQ(CacheEntries(options.sfm_cache_dir), 1);

  // A second load reads the entry: the same cameras, graph and range, and no new entry.
  const LoadedDbarfScene second = LoadDbarfScene(scene, options);
  EXPECT_TRUE(second.estimated_here);
  EXPECT_TRUE(torch::allclose(first.scene.cam_from_world, second.scene.cam_from_world, 1e-6, 1e-6));
  EXPECT_EQ(first.scene.neighbours, second.scene.neighbours);
  EXPECT_EQ(first.scene.usable, second.scene.usable);
  EXPECT_DOUBLE_EQ(first.scene.near, second.scene.near);
  EXPECT_DOUBLE_EQ(first.scene.far, second.scene.far);
  EXPECT_EQ(CacheEntries(options.sfm_cache_dir), 1);

  // The entry really is what the second load used: a doctored entry changes its cameras.
  std::string entry;
  for (const auto& e : std::filesystem::directory_iterator(options.sfm_cache_dir)) entry = e.path().string();
  Json json = ReadJsonFile(entry);
  json["near"] = json["near"].get<double>() * 0.5;
  WriteJsonFile(entry, json);
  EXPECT_DOUBLE_EQ(LoadDbarfScene(scene, options).scene.near, first.scene.near * 0.5);

  // Other images (another size) are another key: a new entry, estimated afresh.
  DbarfSceneOptions smaller = options;
  smaller.max_width = 64;
  const LoadedDbarfScene third = LoadDbarfScene(scene, smaller);
  EXPECT_EQ(third.scene.images.size(3), 64);
  EXPECT_EQ(CacheEntries(options.sfm_cache_dir), 2);

  // A damaged entry is ignored (one more SfM run), never a failure or a wrong camera.
  WriteFileAtomic(entry, "{ not json");
  const LoadedDbarfScene fourth = LoadDbarfScene(scene, options);
  EXPECT_TRUE(torch::allclose(first.scene.cam_from_world, fourth.scene.cam_from_world, 1e-6, 1e-6));
  EXPECT_DOUBLE_EQ(fourth.scene.near, first.scene.near);
}

// --scene-cameras ground-truth: the dataset's cameras in dbarf poses' frame, with their relative
// poses kept up to the frame's scale, the nearest cameras as neighbours, the frames' depth range.
TEST(DbarfScene, GroundTruthCamerasAreTheDatasetsInThePosedFrame) {
  ScopedTempDir dir;
  const std::string path = RenderForwardScene(dir, 7);
  DbarfSceneOptions options;
  options.cameras = "ground-truth";
  const LoadedDbarfScene loaded = LoadDbarfScene(path, options);
  const DbarfScene& s = loaded.scene;
  const Dataset truth = ReadCameras(path);
  ASSERT_EQ(s.NumViews(), 8);
  // The frame's reference is the first training view (view 0 is the held-out test view here).
  const int ref = static_cast<int>(std::find(s.usable.begin(), s.usable.end(), true) - s.usable.begin());
  ASSERT_LT(ref, 8);
  EXPECT_TRUE(torch::allclose(s.cam_from_world[ref], torch::eye(4), 1e-5, 1e-5));
  // Mean distance of the other training views' centres to the reference: 1.
  const auto centre = [](const Rigid3d& c) { return Eigen::Vector3d(c.Inverse().translation); };
  double mean = 0, true_mean = 0;
  int others = 0;
  for (int v = 0; v < 8; ++v) {
    if (v == ref || !s.usable[v]) continue;
    mean += centre(Rigid3d::FromMatrix(TensorToMatrix4(s.cam_from_world[v]), 1e-3)).norm();
    true_mean += (centre(truth.frames[v].cam_from_world) - centre(truth.frames[ref].cam_from_world)).norm();
    ++others;
  }
  mean /= others, true_mean /= others;
  EXPECT_NEAR(mean, 1.0, 1e-4);
  // Relative poses are the truth's, translations scaled by 1 / true_mean; test views included.
  for (int v = 0; v < 8; ++v) {
    const Rigid3d rel_truth = truth.frames[v].cam_from_world * truth.frames[ref].cam_from_world.Inverse();
    const Eigen::Matrix4d rel = TensorToMatrix4(s.cam_from_world[v]);
    EXPECT_LT((rel.block<3, 3>(0, 0) - rel_truth.rotation.toRotationMatrix()).norm(), 1e-4);
    EXPECT_LT((rel.block<3, 1>(0, 3) - rel_truth.translation / true_mean).norm(), 1e-4);
  }
  // The depth range is the frames' own, in the frame's units, widened as the SfM's estimate is.
  double near = 1e9, far = 0;
  for (const Frame& f : truth.frames) near = std::min(near, f.near), far = std::max(far, f.far);
  EXPECT_NEAR(s.near, near / true_mean * 0.7 / 0.9, 1e-3 * s.near);
  EXPECT_NEAR(s.far, far / true_mean * 1.4 / 1.1, 1e-3 * s.far);
  // Every view's neighbours: the other training views, the nearest first.
  for (int v = 0; v < 8; ++v) {
    EXPECT_EQ(s.neighbours[v], [&] {
      auto n = NearestViews(s, s.cam_from_world[v], 8);
      n.erase(std::remove(n.begin(), n.end(), v), n.end());
      return n;
    }());
  }
  // The supervision is these very cameras; nothing was estimated.
  EXPECT_FALSE(loaded.estimated_here);
  EXPECT_TRUE(torch::allclose(loaded.ground_truth, s.cam_from_world));

  // A dataset without per-frame near / far cannot say its depth range.
  Json json = ReadJsonFile(path + "/transforms.json");
  for (auto& f : json["frames"]) f.erase("near"), f.erase("far");
  WriteJsonFile(path + "/transforms.json", json);
  try {
    LoadDbarfScene(path, options);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("near"), std::string::npos) << e.what();
  }
  options.cameras = "both";
  EXPECT_THROW(options.Check(), InputError);
}

TEST(DbarfScene, ViewDepthRangeSpansTheValidDepthsWidenedWithinTheScenes) {
  // 101 x 101 depths 10..20 in rows, plus an invalid far row that must not count.
  torch::Tensor depth = torch::linspace(10.0, 20.0, 101).unsqueeze(1).expand({101, 101}).contiguous();
  depth = torch::cat({depth, torch::full({1, 101}, 1000.0)});  // [102, 101]
  torch::Tensor valid = torch::ones({102, 101}, torch::kBool);
  valid[101] = false;
  auto [lo, hi] = ViewDepthRange(depth, valid, 1.0, 100.0, 1.2);
  EXPECT_NEAR(lo, 10.1 / 1.2, 1e-3);  // the 1st percentile of the valid ones, widened
  EXPECT_NEAR(hi, 19.9 * 1.2, 1e-3);
  // Never outside the scene's range.
  std::tie(lo, hi) = ViewDepthRange(depth, valid, 9.0, 21.0, 1.2);
  EXPECT_DOUBLE_EQ(lo, 9.0);
  EXPECT_DOUBLE_EQ(hi, 21.0);
  // Too few valid pixels, or a range that would not narrow: the scene's.
  std::tie(lo, hi) = ViewDepthRange(depth, torch::zeros({102, 101}, torch::kBool), 1.0, 100.0, 1.2);
  EXPECT_EQ(std::make_pair(lo, hi), std::make_pair(1.0, 100.0));
  std::tie(lo, hi) = ViewDepthRange(torch::full({8, 8}, 50.0), torch::ones({8, 8}, torch::kBool), 60.0, 100.0, 1.2);
  EXPECT_EQ(std::make_pair(lo, hi), std::make_pair(60.0, 100.0));
  EXPECT_ANY_THROW(ViewDepthRange(depth, valid, 1.0, 100.0, 1.0));
}

}  // namespace
}  // namespace nerfreg
