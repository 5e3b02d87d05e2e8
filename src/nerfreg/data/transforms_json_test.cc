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
  EXPECT_DOUBLE_EQ(d.frames[1].camera.fx, 700);    // per frame wins
  EXPECT_DOUBLE_EQ(d.frames[1].camera.fy, 501.5);  // the rest from the top level
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
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png"}]})")
                .find("t.json: frames[0].transform_matrix"),
            std::string::npos);
  EXPECT_NE(
      err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0],[0,1,0],[0,0,1]]}]})")
          .find("expected a 4x4 matrix"),
      std::string::npos);
  EXPECT_NE(
      err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})")
          .find("rotation"),
      std::string::npos);
  EXPECT_NE(
      err(R"({"w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})")
          .find("fl_x or camera_angle_x"),
      std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": []})").find("frames"), std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "frames": [)").find("expected valid JSON"), std::string::npos);
  EXPECT_NE(
      err(R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,NaN],[0,0,0,1]]}]})")
          .find("t.json"),
      std::string::npos);
  // One image listed twice.
  const std::string twice = R"({"fl_x": 10, "w": 4, "h": 4, "frames": [
      {"file_path": "a/x.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},
      {"file_path": "./a/x.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})";
  EXPECT_NE(err(twice).find("unique image names, 'a/x.png' repeats"), std::string::npos) << err(twice);
  // No sizes and a missing image: the image path is named.
  EXPECT_NE(
      err(R"({"camera_angle_x": 0.7, "frames": [{"file_path": "./train/r_9", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})")
          .find("r_9.png"),
      std::string::npos);
}

// Two captures merged into one file (reg register-many --merged-cameras) repeat file names in
// different folders: the frames are then named by their paths, all of them, so none is lost.
TEST(TransformsJson, RepeatedFileNamesInDifferentFoldersAreNamedByTheirPaths) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("t.json"), R"({"fl_x": 10, "w": 4, "h": 4, "frames": [
      {"file_path": "a/x.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},
      {"file_path": "./b/x.png", "transform_matrix": [[1,0,0,1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},
      {"file_path": "b/y.png", "transform_matrix": [[1,0,0,2],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
  const Dataset d = ReadTransformsJson(dir.File("t.json"));
  ASSERT_EQ(d.frames.size(), 3u);
  EXPECT_EQ(d.frames[0].name, "a/x.png");
  EXPECT_EQ(d.frames[1].name, "b/x.png");
  EXPECT_EQ(d.frames[2].name, "b/y.png");
}

TEST(TransformsJson, ReadsNerfstudioModelsDistortionAndPerFrameIntrinsics) {
  // As ns-process-data writes it: OPENCV_FISHEYE with k1..k4 at the top level, one frame with its
  // own intrinsics (per frame wins), applied_transform, and dataparser_transforms.json beside.
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("transforms.json"), R"({
    "camera_model": "OPENCV_FISHEYE", "fl_x": 300, "fl_y": 301, "cx": 320, "cy": 240, "w": 640, "h": 480,
    "k1": 0.05, "k2": -0.01, "k3": 0.002, "k4": -0.0005,
    "applied_transform": [[0,1,0,0],[1,0,0,0],[0,0,-1,0]],
    "frames": [
      {"file_path": "images/frame_00001.jpg", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
      {"file_path": "images/frame_00002.jpg", "fl_x": 250, "camera_model": "OPENCV", "k1": -0.1, "p1": 0.001,
       "transform_matrix": [[1,0,0,1],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}
    ]})");
  WriteFileAtomic(dir.File("dataparser_transforms.json"),
                  R"({"transform": [[0,-1,0,0.5],[1,0,0,0],[0,0,1,-1]], "scale": 0.25})");
  const Dataset d = ReadTransformsJson(dir.File("transforms.json"));
  const Camera& a = d.frames[0].camera;
  EXPECT_EQ(a.model, CameraModel::kOpenCVFisheye);
  EXPECT_DOUBLE_EQ(a.fy, 301);
  EXPECT_DOUBLE_EQ(a.k3, 0.002);
  EXPECT_DOUBLE_EQ(a.k4, -0.0005);
  const Camera& b = d.frames[1].camera;
  EXPECT_EQ(b.model, CameraModel::kOpenCV);
  EXPECT_DOUBLE_EQ(b.fx, 250);
  EXPECT_DOUBLE_EQ(b.fy, 301);
  EXPECT_DOUBLE_EQ(b.k1, -0.1);   // its own
  EXPECT_DOUBLE_EQ(b.k2, -0.01);  // the shared one
  EXPECT_DOUBLE_EQ(b.p1, 0.001);
  ASSERT_TRUE(d.applied_transform.has_value());
  EXPECT_DOUBLE_EQ((*d.applied_transform)(2, 2), -1);
  // dataparser: p_trained = 0.25 * (R p + t); the point (1, 0, 0) goes to 0.25 * ((0, 1, 0) + t).
  ASSERT_TRUE(d.trained_from_data.has_value());
  const Eigen::Vector3d p = *d.trained_from_data * Eigen::Vector3d(1, 0, 0);
  EXPECT_TRUE(p.isApprox(0.25 * Eigen::Vector3d(0.5, 1, -1))) << p.transpose();
}

TEST(TransformsJson, NerfstudioWriteReadRoundTripKeepsItsFields) {
  ScopedTempDir dir;
  Dataset d = MakeRingDataset(dir.path(), 4, /*distortion=*/true);
  for (auto& f : d.frames) {
    f.camera.model = CameraModel::kOpenCVFisheye;
    f.camera.p1 = f.camera.p2 = 0;  // fisheye has none
    f.camera.k3 = 0.003;
  }
  Eigen::Matrix<double, 3, 4> applied;
  applied << 0, 1, 0, 0.5, 1, 0, 0, 0, 0, 0, -1, 2;
  d.applied_transform = applied;
  d.trained_from_data =
      Sim3d(0.3, Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(0.1, 0, 0));
  const std::string path = dir.File("out/transforms.json");
  WriteTransformsJson(d, path, TransformsJsonFlavour::kNerfstudio);
  WriteDataparserTransforms(*d.trained_from_data, dir.File("out/dataparser_transforms.json"));
  const Json j = ReadJsonFile(path);
  EXPECT_EQ(j["camera_model"], "OPENCV_FISHEYE");
  EXPECT_FALSE(j.contains("camera_angle_x"));
  EXPECT_FALSE(j["frames"][0].contains("split"));
  EXPECT_EQ(j["test_filenames"].size(), 1u);  // frame 0 is the ring's test view
  const Dataset back = ReadTransformsJson(path);
  ExpectSamePoses(d, back);
  EXPECT_EQ(back.frames[0].split, "test");
  EXPECT_EQ(back.frames[1].split, "train");
  EXPECT_EQ(back.frames[1].camera.model, CameraModel::kOpenCVFisheye);
  EXPECT_DOUBLE_EQ(back.frames[1].camera.k3, 0.003);
  EXPECT_TRUE(back.applied_transform->isApprox(applied));
  EXPECT_TRUE(back.trained_from_data->ToMatrix().isApprox(d.trained_from_data->ToMatrix(), 1e-12));
}

TEST(TransformsJson, BadNerfstudioFieldsAreNamed) {
  ScopedTempDir dir;
  const std::string p = dir.File("transforms.json");
  const std::string frames =
      R"("frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}])";
  auto err = [&](const std::string& text) {
    WriteFileAtomic(p, text);
    return InputErrorOf([&] { ReadTransformsJson(p); });
  };
  EXPECT_NE(err(R"({"camera_model": "EQUIRECTANGULAR", "fl_x": 10, "w": 4, "h": 4, )" + frames + "}")
                .find("transforms.json: camera_model: expected PINHOLE, OPENCV or OPENCV_FISHEYE, got EQUIRECTANGULAR"),
            std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "k3": "x", )" + frames + "}").find("transforms.json: k3: expected"),
            std::string::npos);
  EXPECT_NE(err(R"({"fl_x": 10, "w": 4, "h": 4, "applied_transform": [[1,0,0],[0,1,0]], )" + frames + "}")
                .find("transforms.json: applied_transform: expected"),
            std::string::npos);
  const std::string good = R"({"fl_x": 10, "w": 4, "h": 4, )" + frames + "}";
  WriteFileAtomic(dir.File("dataparser_transforms.json"),
                  R"({"transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0]], "scale": -2})");
  EXPECT_NE(err(good).find("dataparser_transforms.json: scale: expected a positive number"), std::string::npos);
  WriteFileAtomic(dir.File("dataparser_transforms.json"),
                  R"({"transform": [[2,0,0,0],[0,1,0,0],[0,0,1,0]], "scale": 1})");
  EXPECT_NE(err(good).find("dataparser_transforms.json: transform: expected a rotation"), std::string::npos);
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
