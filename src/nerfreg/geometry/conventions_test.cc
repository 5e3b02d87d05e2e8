#include "nerfreg/geometry/conventions.h"

#include <gtest/gtest.h>

#include <random>

#include "nerfreg/geometry/camera.h"

namespace nerfreg {
namespace {

// The project's own projection: OpenCV axes, cam_from_world.
Eigen::Vector2d ProjectInternal(const Camera& cam, const Rigid3d& cam_from_world, const Eigen::Vector3d& x) {
  return cam.ImgFromCam(cam_from_world * x);
}

// Independent projections written from each convention's own definition.
Eigen::Vector2d ProjectOpenGL(const Camera& cam, const Eigen::Matrix4d& c2w, const Eigen::Vector3d& x) {
  const Eigen::Vector3d p = c2w.topLeftCorner<3, 3>().transpose() * (x - c2w.topRightCorner<3, 1>());
  // OpenGL: looks along -z, +y up in the image.
  return {cam.fx * p.x() / -p.z() + cam.cx, -cam.fy * p.y() / -p.z() + cam.cy};
}

Eigen::Vector2d ProjectLlff(const Camera& cam, const Matrix3x4d& c2w, const Eigen::Vector3d& x) {
  const Eigen::Vector3d p = c2w.leftCols<3>().transpose() * (x - c2w.col(3));  // (down, right, back)
  return {cam.fx * p.y() / -p.z() + cam.cx, cam.fy * p.x() / -p.z() + cam.cy};
}

Eigen::Vector2d ProjectNgp(const Camera& cam, const Matrix3x4d& ngp, const Eigen::Vector3d& x_ngp) {
  // instant-ngp's camera matrix columns are right, down, forward in its (scaled) frame.
  const Eigen::Vector3d p = ngp.leftCols<3>().transpose() * (x_ngp - ngp.col(3));
  return {cam.fx * p.x() / p.z() + cam.cx, cam.fy * p.y() / p.z() + cam.cy};
}

TEST(Conventions, OneWorldPointProjectsToTheSamePixelEverywhere) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  const Camera cam = Camera::Pinhole(200, 150, 180, 175, 101.3, 74.2);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d eye(3 + u(rng), u(rng), 1 + u(rng));
    const Eigen::Vector3d target(0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng));
    const Rigid3d cam_from_world = LookAt(eye, target, Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d x = target + 0.3 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Vector2d px = ProjectInternal(cam, cam_from_world, x);

    const Eigen::Matrix4d gl = OpenGLFromCamFromWorld(cam_from_world);
    EXPECT_LT((ProjectOpenGL(cam, gl, x) - px).norm(), 1e-9);
    EXPECT_LT((ProjectInternal(cam, CamFromWorldFromOpenGL(gl), x) - px).norm(), 1e-9);

    const Matrix3x4d llff = LlffFromCamFromWorld(cam_from_world);
    EXPECT_LT((ProjectLlff(cam, llff, x) - px).norm(), 1e-9);
    EXPECT_LT((ProjectInternal(cam, CamFromWorldFromLlff(llff), x) - px).norm(), 1e-9);

    const Eigen::Vector3d offset(0.5, 0.5, 0.5);
    const Matrix3x4d ngp = NgpFromOpenGL(gl, 0.33, offset);
    EXPECT_LT((ProjectNgp(cam, ngp, NgpPointFromWorld(x, 0.33, offset)) - px).norm(), 1e-9);
    EXPECT_LT((OpenGLFromNgp(ngp, 0.33, offset) - gl).norm(), 1e-12);
    EXPECT_LT((WorldPointFromNgp(NgpPointFromWorld(x)) - x).norm(), 1e-12);
  }
}

TEST(Conventions, LookAtLooksAtTarget) {
  const Eigen::Vector3d eye(0, -4, 1), target(0, 0, 0);
  const Rigid3d cam_from_world = LookAt(eye, target, Eigen::Vector3d::UnitZ());
  EXPECT_LT((CameraCenter(cam_from_world) - eye).norm(), 1e-12);
  const Eigen::Vector3d t = cam_from_world * target;
  EXPECT_NEAR(t.x(), 0, 1e-12);
  EXPECT_NEAR(t.y(), 0, 1e-12);
  EXPECT_GT(t.z(), 0);
  // World up appears upwards in the image (negative y in OpenCV axes).
  EXPECT_LT((cam_from_world * Eigen::Vector3d(0, 0, 1)).y(), 0);
  EXPECT_THROW(LookAt(eye, eye, Eigen::Vector3d::UnitZ()), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
