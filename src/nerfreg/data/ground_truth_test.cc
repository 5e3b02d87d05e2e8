#include "nerfreg/data/ground_truth.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(GroundTruth, TargetFromSourceMapsSourcePointsOntoTargetPoints) {
  ScopedTempDir dir;
  Sim3d a, b;
  a.scale = 1.5;
  a.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  a.translation = Eigen::Vector3d(0.3, -1, 2);
  b.scale = 0.8;
  b.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitZ()));
  b.translation = Eigen::Vector3d(-2, 0.5, 0.1);
  WriteJsonFile(
      dir.File("gt.json"),
      {{"blocks",
        {{{"block_from_world", MatrixToJson(a.ToMatrix())}}, {{"block_from_world", MatrixToJson(b.ToMatrix())}}}}});
  const GroundTruthFile gt(dir.File("gt.json"));
  const Sim3d b_from_a = gt.TargetFromSource(0, 1);
  const Eigen::Vector3d x_world(0.4, -0.2, 1.3);
  EXPECT_LT((b_from_a * (a * x_world) - b * x_world).norm(), 1e-9);
  EXPECT_LT((gt.BlockFromWorld(1).ToMatrix() - b.ToMatrix()).norm(), 1e-9);
}

TEST(GroundTruth, AMissingBlockIsAnInputErrorAndABadMatrixIsNotASimilarity) {
  ScopedTempDir dir;
  Eigen::Matrix4d shear = Eigen::Matrix4d::Identity();
  shear(0, 1) = 0.5;
  WriteJsonFile(dir.File("gt.json"), {{"blocks", {{{"block_from_world", MatrixToJson(shear)}}}}});
  const GroundTruthFile gt(dir.File("gt.json"));
  EXPECT_NE(InputErrorOf([&] { gt.BlockFromWorld(3); }).find("gt.json"), std::string::npos);
  EXPECT_THROW(gt.BlockFromWorld(0), std::invalid_argument);
  EXPECT_NE(InputErrorOf([&] { GroundTruthFile(dir.File("missing.json")); }), "");
}

}  // namespace
}  // namespace nerfreg
