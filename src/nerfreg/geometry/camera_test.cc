#include "nerfreg/geometry/camera.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nerfreg {
namespace {

TEST(Camera, ProjectUnprojectRoundTripWithDistortion) {
  Camera cam = Camera::Pinhole(640, 480, 500, 510, 320.5, 239.5);
  cam.k1 = -0.2;
  cam.k2 = 0.05;
  cam.p1 = 0.001;
  cam.p2 = -0.002;
  for (double x : {-0.4, 0.0, 0.3})
    for (double y : {-0.3, 0.1, 0.35}) {
      const Eigen::Vector3d p(x, y, 1.0);
      const Eigen::Vector2d uv = cam.ImgFromCam(p * 2.5);
      EXPECT_LT((cam.CamFromImg(uv) - p).norm(), 1e-10);
    }
}

TEST(Camera, FisheyeIsEquidistantAndRoundTrips) {
  Camera c = Camera::Pinhole(640, 480, 300, 300, 320, 240);
  c.model = CameraModel::kOpenCVFisheye;
  // k = 0: the image radius is f * theta, the angle to the axis (a pinhole would give f tan theta).
  const Eigen::Vector2d uv = c.ImgFromCam(Eigen::Vector3d(std::tan(1.0), 0, 1));
  EXPECT_NEAR(uv.x(), 320 + 300 * 1.0, 1e-9);
  c.k1 = 0.05;
  c.k2 = -0.01;
  c.k3 = 0.002;
  c.k4 = -0.0005;
  EXPECT_TRUE(c.HasDistortion());
  for (const Eigen::Vector3d x :
       {Eigen::Vector3d(0.3, -0.2, 1), Eigen::Vector3d(1.5, 1.0, 1), Eigen::Vector3d(0, 0, 2)}) {
    const Eigen::Vector3d back = c.CamFromImg(c.ImgFromCam(x));
    EXPECT_NEAR(back.x(), x.x() / x.z(), 1e-8);
    EXPECT_NEAR(back.y(), x.y() / x.z(), 1e-8);
  }
  // nerfstudio's OPENCV radial terms k3 (r^6) and k4 (r^8) move points and invert.
  Camera o = Camera::Pinhole(640, 480, 300, 300, 320, 240);
  o.k3 = 0.01;
  o.k4 = 0.005;
  const Eigen::Vector3d x(0.8, 0.6, 1);  // r^2 = 1
  EXPECT_NEAR(o.ImgFromCam(x).x(), 320 + 300 * 0.8 * 1.015, 1e-9);
  EXPECT_NEAR(o.CamFromImg(o.ImgFromCam(x)).x(), 0.8, 1e-9);
}

TEST(Camera, OpticalAxisHitsPrincipalPoint) {
  const Camera cam = Camera::FromFovX(800, 800, 0.6911112070083618);
  EXPECT_NEAR(cam.fx, 1111.111, 1e-2);  // the NeRF-synthetic focal length
  const Eigen::Vector2d uv = cam.ImgFromCam({0, 0, 3});
  EXPECT_DOUBLE_EQ(uv.x(), 400);
  EXPECT_DOUBLE_EQ(uv.y(), 400);
  EXPECT_NEAR(cam.FovX(), 0.6911112070083618, 1e-12);
}

TEST(Camera, ResizedScalesAllFour) {
  const Camera cam = Camera::Pinhole(504, 378, 400, 410, 252, 189);
  const Camera half = cam.Resized(252, 189);
  EXPECT_DOUBLE_EQ(half.fx, 200);
  EXPECT_DOUBLE_EQ(half.fy, 205);
  EXPECT_DOUBLE_EQ(half.cx, 126);
  EXPECT_DOUBLE_EQ(half.cy, 94.5);
  // The same ray maps to the same relative image position.
  const Eigen::Vector3d p(0.1, -0.2, 1.0);
  EXPECT_NEAR(half.ImgFromCam(p).x() / 252, cam.ImgFromCam(p).x() / 504, 1e-12);
}

TEST(Camera, CheckRejectsBadIntrinsics) {
  EXPECT_THROW(Camera::Pinhole(0, 10, 1, 1, 0, 0).Check(), std::invalid_argument);
  EXPECT_THROW(Camera::Pinhole(10, 10, -1, 1, 0, 0).Check(), std::invalid_argument);
  EXPECT_NO_THROW(Camera::Pinhole(10, 10, 1, 1, 5, 5).Check());
}

}  // namespace
}  // namespace nerfreg
