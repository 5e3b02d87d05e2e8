#include "nerfreg/dbarf_data/dbarf_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <tuple>
#include <utility>

#include "nerfreg/data/convert.h"
#include "nerfreg/data/test_data.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// 8 cameras on a ring (views 0 and 4 held out as test views), 24 x 16 images, per-frame near / far:
// the ground-truth path needs no real pixels, and the learned-core build has no renderer.
std::string WriteRingScene(const ScopedTempDir& dir) {
  const std::string out = dir.File("scene");
  WriteTransformsJson(MakeRingDataset(out, 8), JoinPaths(out, "transforms.json"));
  return out;
}

// --scene-cameras ground-truth: the dataset's cameras in dbarf poses' frame, with their relative
// poses kept up to the frame's scale, the nearest cameras as neighbours, the frames' depth range.
TEST(DbarfScene, GroundTruthCamerasAreTheDatasetsInThePosedFrame) {
  ScopedTempDir dir;
  const std::string path = WriteRingScene(dir);
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
  // Unless it has a scene box (object datasets): then the depths of the box's corners bound it.
  json["aabb"] = {{-1.0, -1.0, -1.0}, {1.0, 1.0, 1.0}};
  WriteJsonFile(path + "/transforms.json", json);
  const DbarfScene boxed = LoadDbarfScene(path, options).scene;
  double box_near = 1e9, box_far = 0;
  const Eigen::AlignedBox3d box(Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1));
  for (const Frame& f : truth.frames) {
    for (int corner = 0; corner < 8; ++corner) {
      const double z = (f.cam_from_world * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner))).z();
      box_near = std::min(box_near, z), box_far = std::max(box_far, z);
    }
  }
  ASSERT_GT(box_near, 0);  // every camera outside the box
  EXPECT_NEAR(boxed.near, box_near / true_mean * 0.7 / 0.9, 1e-3 * boxed.near);
  EXPECT_NEAR(boxed.far, box_far / true_mean * 1.4 / 1.1, 1e-3 * boxed.far);
  options.cameras = "both";
  EXPECT_THROW(options.Check(), InputError);
}

// "estimated" cameras come from the estimator the caller gives, which sees the images at the
// loaded size; without one, such a dataset is refused by name (the learned-core build).
TEST(DbarfScene, EstimatedCamerasComeFromTheEstimatorGivenAndWithoutOneTheDatasetIsRefused) {
  ScopedTempDir dir;
  const std::string path = WriteRingScene(dir);
  DbarfSceneOptions options;
  options.max_width = 12;
  int calls = 0;
  options.estimate_cameras = [&](const std::string& p, const std::vector<Image>& images,
                                 const std::vector<Camera>& cameras, int max_width, DbarfScene* scene,
                                 std::vector<std::string>* not_posed) {
    ++calls;
    EXPECT_EQ(p, path);
    ASSERT_EQ(images.size(), 8u);
    EXPECT_EQ(images[0].width, 12);
    EXPECT_EQ(images[0].height, 8);
    EXPECT_DOUBLE_EQ(cameras[0].fx, 10.0);  // 20 at 24 wide
    EXPECT_EQ(max_width, 12);
    // Every camera a step along x; view 7 not posed.
    std::vector<torch::Tensor> cams;
    for (int v = 0; v < 8; ++v) {
      torch::Tensor c = torch::eye(4);
      c[0][3] = -0.5 * v;
      cams.push_back(c);
    }
    scene->cam_from_world = torch::stack(cams);
    scene->neighbours.assign(8, {});
    for (int v = 0; v < 8; ++v) scene->neighbours[v] = {(v + 1) % 8};
    scene->near = 0.5;
    scene->far = 9.0;
    scene->usable[7] = false;
    not_posed->push_back(scene->image_names[7]);
  };
  const LoadedDbarfScene loaded = LoadDbarfScene(path, options);
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(loaded.estimated_here);
  EXPECT_FLOAT_EQ(loaded.scene.cam_from_world[3][0][3].item<float>(), -1.5f);
  EXPECT_DOUBLE_EQ(loaded.scene.far, 9.0);
  EXPECT_EQ(loaded.not_posed, std::vector<std::string>{"img_107.png"});
  EXPECT_FALSE(loaded.scene.usable[7]);
  // The dataset's own poses are kept apart, for evaluation.
  ASSERT_TRUE(loaded.ground_truth.defined());
  const Dataset truth = ReadCameras(path);
  EXPECT_TRUE(torch::allclose(loaded.ground_truth[2], Matrix4ToTensor(truth.frames[2].cam_from_world.ToMatrix())));

  options.estimate_cameras = nullptr;
  try {
    LoadDbarfScene(path, options);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find("--scene-cameras ground-truth"), std::string::npos) << what;
  }
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
