#include "nerfreg/dbarf_data/posed_images.h"

#include <gtest/gtest.h>

#include "nerfreg/data/convert.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Three posed frames in `dir`, the second posed by the network, with a view graph and depth range.
PosedImages ThreeImages(const std::string& dir) {
  PosedImages posed;
  posed.dataset.root = dir;
  for (int k = 0; k < 3; ++k) {
    Frame f;
    f.name = "im_" + std::to_string(k) + ".png";
    f.file_path = "images/" + f.name;
    f.camera = Camera::Pinhole(64, 48, 50, 50, 32, 24);
    f.cam_from_world = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d::UnitY())),
                               Eigen::Vector3d(0.5 * k, 0, 0));
    posed.dataset.frames.push_back(f);
    posed.posed_by.push_back(k == 1 ? "network" : "sfm");
    posed.confidence.push_back(ImagePoseConfidence{});
  }
  posed.not_posed = {"im_3.png"};
  posed.view_graph =
      Json::array({{"im_0.png", "im_1.png", 120}, {"im_1.png", "im_2.png", 0}, {"im_3.png", "im_0.png", 7}});
  posed.info = {{"near", 0.25}, {"far", 9.5}, {"method", "auto"}};
  return posed;
}

TEST(PosedImagesTest, WhatIsWrittenIsReadBack) {
  ScopedTempDir tmp;
  const PosedImages posed = ThreeImages(tmp.path());
  const std::string path = tmp.File("transforms.json");
  WritePosedImages(path, posed);
  const Json json = ReadJsonFile(path);
  ASSERT_TRUE(IsPosedImages(json));
  EXPECT_EQ(json["frames"][1]["posed_by"], "network");
  EXPECT_EQ(json["not_posed"][0], "im_3.png");
  EXPECT_TRUE(json.contains("confidence_doc"));
  const PosedImagesInfo info = ReadPosedImagesInfo(json, path);
  EXPECT_DOUBLE_EQ(info.near, 0.25);
  EXPECT_DOUBLE_EQ(info.far, 9.5);
  ASSERT_EQ(info.view_graph.size(), 3u);
  EXPECT_EQ(info.view_graph[0].a, "im_0.png");
  EXPECT_EQ(info.view_graph[0].b, "im_1.png");
  EXPECT_EQ(info.view_graph[0].inliers, 120);
  EXPECT_EQ(info.view_graph[2].inliers, 7);
  // The cameras are those written.
  const Dataset d = ReadCameras(path);
  ASSERT_EQ(d.frames.size(), 3u);
  EXPECT_LT((d.frames[2].cam_from_world.ToMatrix() - posed.dataset.frames[2].cam_from_world.ToMatrix()).norm(), 1e-6);
}

TEST(PosedImagesTest, ADatasetIsNotPosedImagesAndAMissingDepthRangeIsNamed) {
  EXPECT_FALSE(IsPosedImages(Json{{"frames", Json::array()}}));
  const Json json = {{"view_graph", Json::array()}, {"dbarf_poses", {{"near", 1.0}}}};
  EXPECT_NE(InputErrorOf([&] { ReadPosedImagesInfo(json, "p.json"); }).find("far"), std::string::npos);
}

TEST(PosedImagesTest, RefinedCamerasKeepTheViewGraphAndAreMarked) {
  ScopedTempDir tmp;
  const PosedImages posed = ThreeImages(tmp.path());
  WritePosedImages(tmp.File("transforms.json"), posed);
  Dataset refined = posed.dataset;
  refined.frames[0].cam_from_world = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1));
  CreateDirectories(tmp.File("out"));
  WriteRefinedPosedImages(tmp.File("transforms.json"), refined, tmp.File("out/refined.json"));
  const Json json = ReadJsonFile(tmp.File("out/refined.json"));
  EXPECT_EQ(json["view_graph"], posed.view_graph);
  EXPECT_EQ(json["not_posed"][0], "im_3.png");
  EXPECT_TRUE(json["dbarf_poses"].contains("refined"));
  // Image paths now relative to the output's folder.
  EXPECT_EQ(json["frames"][0]["file_path"].get<std::string>().rfind("../images/", 0), 0u)
      << json["frames"][0]["file_path"];
  const Dataset d = ReadCameras(tmp.File("out/refined.json"));
  EXPECT_LT((d.frames[0].cam_from_world.translation - Eigen::Vector3d(0, 0, 1)).norm(), 1e-6);
}

}  // namespace
}  // namespace nerfreg
