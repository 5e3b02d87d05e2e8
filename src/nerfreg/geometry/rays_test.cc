#include "nerfreg/geometry/rays.h"

#include <gtest/gtest.h>

#include "nerfreg/geometry/conventions.h"

namespace nerfreg {
namespace {

TEST(Rays, EveryRayReprojectsToItsPixelCentre) {
  const Camera cam = Camera::Pinhole(8, 6, 7, 7.5, 4.2, 2.9);
  const Rigid3d cam_from_world = LookAt({1, 2, 3}, {0, 0, 0}, Eigen::Vector3d::UnitZ());
  Eigen::Matrix3Xd o, d;
  Eigen::VectorXd z;
  GenerateRays(cam, cam_from_world, &o, &d, &z);
  ASSERT_EQ(d.cols(), 48);
  for (int row = 0; row < 6; ++row)
    for (int col = 0; col < 8; ++col) {
      const int i = row * 8 + col;
      EXPECT_NEAR(d.col(i).norm(), 1.0, 1e-12);
      const Eigen::Vector3d x = o.col(i) + 2.0 * d.col(i);
      const Eigen::Vector3d x_cam = cam_from_world * x;
      EXPECT_NEAR(x_cam.z(), 2.0 * z(i), 1e-12);  // z-depth = distance * z_dir
      const Eigen::Vector2d uv = cam.ImgFromCam(x_cam);
      EXPECT_NEAR(uv.x(), col + 0.5, 1e-9);
      EXPECT_NEAR(uv.y(), row + 0.5, 1e-9);
    }
  const Ray r = RayFromPixel(cam, cam_from_world, {3.5, 2.5});
  EXPECT_LT((r.direction - d.col(2 * 8 + 3)).norm(), 1e-12);
}

}  // namespace
}  // namespace nerfreg
