#include "nerfreg/geometry/conventions.h"

#include <stdexcept>

namespace nerfreg {
namespace {
// Camera axes OpenGL (x right, y up, z back) -> OpenCV (x right, y down, z forward): flip y, z.
const Eigen::Matrix3d kGlFromCv = Eigen::Vector3d(1, -1, -1).asDiagonal();
// LLFF columns (down, right, back) expressed in OpenCV axes: down = +y, right = +x, back = -z.
Eigen::Matrix3d CvFromLlff() {
  Eigen::Matrix3d m;
  m.col(0) = Eigen::Vector3d(0, 1, 0);
  m.col(1) = Eigen::Vector3d(1, 0, 0);
  m.col(2) = Eigen::Vector3d(0, 0, -1);
  return m;
}
}  // namespace

Rigid3d CamFromWorldFromOpenGL(const Eigen::Matrix4d& world_from_cam_gl) {
  Eigen::Matrix4d world_from_cam_cv = world_from_cam_gl;
  world_from_cam_cv.topLeftCorner<3, 3>() = world_from_cam_gl.topLeftCorner<3, 3>() * kGlFromCv;
  return Rigid3d::FromMatrix(world_from_cam_cv).Inverse();
}

Eigen::Matrix4d OpenGLFromCamFromWorld(const Rigid3d& cam_from_world) {
  Eigen::Matrix4d m = cam_from_world.Inverse().ToMatrix();
  m.topLeftCorner<3, 3>() = m.topLeftCorner<3, 3>() * kGlFromCv;  // kGlFromCv is its own inverse
  return m;
}

Rigid3d CamFromWorldFromLlff(const Matrix3x4d& world_from_cam_llff) {
  Matrix3x4d world_from_cam_cv = world_from_cam_llff;
  // world_from_llff * llff_from_cv, with llff_from_cv = CvFromLlff()^T.
  world_from_cam_cv.leftCols<3>() = world_from_cam_llff.leftCols<3>() * CvFromLlff().transpose();
  return Rigid3d::FromMatrix(world_from_cam_cv).Inverse();
}

Matrix3x4d LlffFromCamFromWorld(const Rigid3d& cam_from_world) {
  Matrix3x4d m = cam_from_world.Inverse().ToMatrix3x4();
  m.leftCols<3>() = m.leftCols<3>() * CvFromLlff();
  return m;
}

Matrix3x4d NgpFromOpenGL(const Eigen::Matrix4d& gl, double scale, const Eigen::Vector3d& offset) {
  // instant-ngp nerf_matrix_to_ngp: negate y and z columns, scale+offset the translation, then
  // cycle the rows xyz <- yzx.
  Matrix3x4d m = gl.topRows<3>();
  m.col(1) *= -1;
  m.col(2) *= -1;
  m.col(3) = m.col(3) * scale + offset;
  Matrix3x4d out;
  out.row(0) = m.row(1);
  out.row(1) = m.row(2);
  out.row(2) = m.row(0);
  return out;
}

Eigen::Matrix4d OpenGLFromNgp(const Matrix3x4d& ngp, double scale, const Eigen::Vector3d& offset) {
  Matrix3x4d m;
  m.row(1) = ngp.row(0);
  m.row(2) = ngp.row(1);
  m.row(0) = ngp.row(2);
  m.col(1) *= -1;
  m.col(2) *= -1;
  m.col(3) = (m.col(3) - offset) / scale;
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.topRows<3>() = m;
  return out;
}

Eigen::Vector3d NgpPointFromWorld(const Eigen::Vector3d& x, double scale, const Eigen::Vector3d& offset) {
  const Eigen::Vector3d p = x * scale + offset;
  return {p.y(), p.z(), p.x()};
}

Eigen::Vector3d WorldPointFromNgp(const Eigen::Vector3d& p, double scale, const Eigen::Vector3d& offset) {
  const Eigen::Vector3d q(p.z(), p.x(), p.y());
  return (q - offset) / scale;
}

Eigen::Vector3d CameraCenter(const Rigid3d& cam_from_world) {
  return -(cam_from_world.rotation.conjugate() * cam_from_world.translation);
}

Rigid3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = target - eye;
  if (z.norm() < 1e-12) throw std::invalid_argument("LookAt: eye equals target");
  const Eigen::Vector3d zn = z.normalized();
  // OpenCV axes (x right, y down, z forward): x = y cross z with y ~ -up, i.e. z cross up.
  Eigen::Vector3d x = zn.cross(up);
  if (x.norm() < 1e-9) throw std::invalid_argument("LookAt: up is parallel to the view direction");
  x.normalize();
  const Eigen::Vector3d y = zn.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam.col(0) = x;
  world_from_cam.col(1) = y;
  world_from_cam.col(2) = zn;
  return Rigid3d(world_from_cam, eye).Inverse();
}

}  // namespace nerfreg
