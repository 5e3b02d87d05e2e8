#include "nerfreg/data/transforms_json.h"

#include <gtest/gtest.h>

#include "nerfreg/data/test_data.h"
#include "nerfreg/geometry/conventions.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(TransformsJson, RoundTripKeepsPosesIntrinsicsSplitsAndBounds) {
  ScopedTempDir dir;
  Dataset d = MakeRingDataset(dir.path(), 6, /*distortion=*/true);
  d.aabb_scale = 4;
  d.aabb_min = Eigen::Vector3d(-1.5, -1.5, -1.5);
  d.aabb_max = Eigen::Vector3d(1.5, 1.5, 1.5);
  WriteTransformsJson(d, dir.File("transforms.json"));
  const Dataset back = ReadTransformsJson(dir.File("transforms.json"));
  ExpectSamePoses(d, back);
  EXPECT_EQ(back.frames[0].split, "test");
  EXPECT_EQ(back.frames[1].split, "train");
  EXPECT_DOUBLE_EQ(back.frames[2].camera.k1, -0.05);
  EXPECT_DOUBLE_EQ(back.frames[2].far, 6.0);
  EXPECT_EQ(*back.aabb_scale, 4);
  EXPECT_NO_THROW(CheckImagesMatchCameras(back));
}

TEST(TransformsJson, ReadsNerfSyntheticWithoutSizesOrExtensions) {
  // Blender's files: camera_angle_x only, paths without ".png", size from the images.
  ScopedTempDir dir;
  WriteImage(dir.File("train/r_0.png"), Image(40, 30, 4));
  WriteImage(dir.File("train/r_1.png"), Image(40, 30, 4));
  WriteFileAtomic(dir.File("transforms_train.json"), R"({
    "camera_angle_x": 0.6911112070083618,
    "frames": [
      {"file_path": "./train/r_0", "rotation": 0.012, "transform_matrix": [[-1,0,0,0],[0,-0.7341,0.6790,2.7373],[0,0.6790,0.7341,2.9593],[0,0,0,1]]},
      {"file_path": "./train/r_1", "rotation": 0.012, "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}
    ]})");
  const Dataset d = ReadTransformsJson(dir.File("transforms_train.json"));
  ASSERT_EQ(d.frames.size(), 2u);
  EXPECT_EQ(d.frames[0].name, "r_0.png");
  EXPECT_EQ(d.frames[0].camera.width, 40);
  EXPECT_NEAR(d.frames[0].camera.fx, 0.5 * 40 / std::tan(0.5 * 0.6911112070083618), 1e-9);
  EXPECT_DOUBLE_EQ(d.frames[0].camera.cx, 20);
  // Camera 1 sits at (0, 0, 4) looking down -z (OpenGL): the origin projects to the centre.
  const Eigen::Vector2d uv = d.frames[1].camera.ImgFromCam(d.frames[1].cam_from_world * Eigen::Vector3d::Zero());
  EXPECT_NEAR(uv.x(), 20, 1e-9);
  EXPECT_NEAR(uv.y(), 15, 1e-9);
}

TEST(TransformsJson, ReadsInstantNgpFieldsPerFrameAndTopLevel) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("transforms.json"), R"({
    "fl_x": 500.5, "fl_y": 501.5, "cx": 320.1, "cy": 239.9, "w": 640, "h": 480,
    "k1": -0.1, "k2": 0.01, "p1": 0.001, "p2": -0.002, "aabb_scale": 16, "scale": 0.5, "offset": [0.5, 0.5, 0.5],
    "frames": [
      {"file_path": "images/0001.jpg", "sharpness": 31.2, "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
      {"file_path": "images/0002.jpg", "fl_x": 700, "w": 640, "h": 480, "transform_matrix": [[1,0,0,1],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}
    ]})");
  const Dataset d = ReadTransformsJson(dir.File("transforms.json"));
  EXPECT_DOUBLE_EQ(d.frames[0].camera.fx, 500.5);
  EXPECT_DOUBLE_EQ(d.frames[0].camera.fy, 501.5);
  EXPECT_DOUBLE_EQ(d.frames[0].camera.p2, -0.002);
  EXPECT_DOUBLE_EQ(d.frames[1].camera.fx, 700);   // per frame wins
  EXPECT_DOUBLE_EQ(d.frames[1].camera.fy, 501.5); // the rest from the top level
  EXPECT_EQ(*d.aabb_scale, 16);
  EXPECT_DOUBLE_EQ(*d.ngp_scale, 0.5);
  // Writing back keeps per-frame intrinsics where they differ.
  WriteTransformsJson(d, dir.File("out.json"));
  ExpectSamePoses(d, ReadTransformsJson(dir.File("out.json")));
}

TEST(TransformsJson, BadFilesNameTheFileAndField) {
  ScopedTempDir dir;
  const std::string p = dir.File("t.json");
  auto err = [&](const std::string& text) {
    WriteFileAtomic(p, text);
    return InputErrorOf([&] { ReadTransformsJson(p); });
  };
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png"}]})").find("t.json: frames[0].transform_matrix"), std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0],[0,1,0],[0,0,1]]}]})")
                .find("expected a 4x4 matrix"), std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})")
                .find("rotation"), std::string::npos);
  EXPECT_NE(err(R"({"w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})")
                .find("fl_x or camera_angle_x"), std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": []})").find("frames"), std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "frames": [)").find("expected valid JSON"), std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,NaN],[0,0,0,1]]}]})")
                .find("t.json"), std::string::npos);
  const std::string two = R"({"fl_x": 10, "w": 4, "h": 4, "frames": [
      {"file_path": "a/x.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},
      {"file_path": "b/x.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})";
  EXPECT_NE(err(two).find("unique image names"), std::string::npos);
  // No sizes and a missing image: the image path is named.
  EXPECT_NE(err(R"({"camera_angle_x": 0.7, "frames": [{"file_path": "./train/r_9", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})")
                .find("r_9.png"), std::string::npos);
}

TEST(TransformsJson, ImageSizeDifferentFromCamerasIsNamed) {
  ScopedTempDir dir;
  Dataset d = MakeRingDataset(dir.path(), 2);
  WriteImage(d.ImagePath(d.frames[1]), Image(10, 10, 3));
  const std::string msg = InputErrorOf([&] { CheckImagesMatchCameras(d); });
  EXPECT_NE(msg.find(d.frames[1].name + ": size: expected 24x16"), std::string::npos) << msg;
}

}  // namespace
}  // namespace nerfreg
