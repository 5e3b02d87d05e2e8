#include "nerfreg/render/point_splat.h"

#include <gtest/gtest.h>

#include "nerfreg/geometry/conventions.h"

namespace nerfreg {
namespace {

TEST(PointSplat, NearerPointWinsAtItsPixel) {
  const Camera cam = Camera::Pinhole(21, 21, 20, 20, 10.5, 10.5);
  const Rigid3d cam_from_world = LookAt({0, -5, 0}, {0, 0, 0}, Eigen::Vector3d::UnitZ());
  ColoredPoints far{Eigen::Matrix3Xd(3, 1), {0, 0, 1}}, near{Eigen::Matrix3Xd(3, 1), {1, 0, 0}};
  far.xyz.col(0) = Eigen::Vector3d(0, 1, 0);
  near.xyz.col(0) = Eigen::Vector3d(0, -1, 0);
  const Image im = SplatPoints({near, far}, cam, cam_from_world, 0);
  EXPECT_FLOAT_EQ(im.at(10, 10, 0), 1.f);  // red (near) over blue (far)
  EXPECT_FLOAT_EQ(im.at(10, 10, 2), 0.f);
  EXPECT_FLOAT_EQ(im.at(0, 0, 0), 1.f);  // background white
  EXPECT_FLOAT_EQ(im.at(0, 0, 2), 1.f);
  const Image sheet = ThreeViewOverlay({near, far}, Eigen::Vector3d::Zero(), 5.0, 32);
  EXPECT_EQ(sheet.width, 3 * 32 + 4);
}

}  // namespace
}  // namespace nerfreg
