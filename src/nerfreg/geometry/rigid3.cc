#include "nerfreg/geometry/rigid3.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace nerfreg {
namespace {

void CheckRotation(const Eigen::Matrix3d& r, double tol, const char* what) {
  const double ortho = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = r.determinant();
  if (!r.allFinite() || ortho > tol || std::abs(det - 1.0) > tol) {
    throw std::invalid_argument(std::string(what) + ": 3x3 block is not a rotation (|R^T R - I| = " +
                                std::to_string(ortho) + ", det = " + std::to_string(det) + ")");
  }
}

// Left Jacobian of SO(3) and its inverse, for the coupled SE(3) exp/log.
Eigen::Matrix3d LeftJacobian(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d W = Skew(w);
  if (theta < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * W;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(theta)) / t2 * W +
         (theta - std::sin(theta)) / (t2 * theta) * W * W;
}

Eigen::Matrix3d LeftJacobianInverse(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d W = Skew(w);
  if (theta < 1e-8) return Eigen::Matrix3d::Identity() - 0.5 * W;
  const double half = 0.5 * theta;
  const double coef = (1.0 - half * std::cos(half) / std::sin(half)) / (theta * theta);
  return Eigen::Matrix3d::Identity() - 0.5 * W + coef * W * W;
}

}  // namespace

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Rigid3d::Rigid3d(const Eigen::Matrix3d& r, const Eigen::Vector3d& t)
    : rotation(Eigen::Quaterniond(r).normalized()), translation(t) {}

Rigid3d Rigid3d::FromMatrix(const Eigen::Matrix4d& m, double tol) {
  return FromMatrix(Matrix3x4d(m.topRows<3>()), tol);
}

Rigid3d Rigid3d::FromMatrix(const Matrix3x4d& m, double tol) {
  const Eigen::Matrix3d r = m.leftCols<3>();
  CheckRotation(r, tol, "Rigid3d::FromMatrix");
  if (!m.col(3).allFinite()) throw std::invalid_argument("Rigid3d::FromMatrix: non-finite translation");
  return Rigid3d(r, m.col(3));
}

Eigen::Matrix4d Rigid3d::ToMatrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRows<3>() = ToMatrix3x4();
  return m;
}

Matrix3x4d Rigid3d::ToMatrix3x4() const {
  Matrix3x4d m;
  m.leftCols<3>() = RotationMatrix();
  m.col(3) = translation;
  return m;
}

Rigid3d Rigid3d::Inverse() const {
  const Eigen::Quaterniond r_inv = rotation.conjugate();
  return Rigid3d(r_inv, -(r_inv * translation));
}

Rigid3d Rigid3d::operator*(const Rigid3d& o) const {
  return Rigid3d(rotation * o.rotation, rotation * o.translation + translation);
}

Rigid3d Rigid3d::Exp(const Vector6d& xi) {
  const Eigen::Vector3d w = xi.head<3>();
  const Eigen::Vector3d v = xi.tail<3>();
  const double theta = w.norm();
  const Eigen::Quaterniond q =
      theta < 1e-12 ? Eigen::Quaterniond::Identity() : Eigen::Quaterniond(Eigen::AngleAxisd(theta, w / theta));
  return Rigid3d(q, LeftJacobian(w) * v);
}

Vector6d Rigid3d::Log() const {
  Eigen::AngleAxisd aa(rotation);
  double angle = aa.angle();
  Eigen::Vector3d axis = aa.axis();
  if (angle > M_PI) {  // keep the shortest rotation vector
    angle = 2 * M_PI - angle;
    axis = -axis;
  }
  const Eigen::Vector3d w = angle * axis;
  Vector6d xi;
  xi.head<3>() = w;
  xi.tail<3>() = LeftJacobianInverse(w) * translation;
  return xi;
}

Sim3d Sim3d::FromMatrix(const Eigen::Matrix4d& m, double tol) {
  const Eigen::Matrix3d sr = m.topLeftCorner<3, 3>();
  const double det = sr.determinant();
  if (!(det > 0) || !std::isfinite(det)) {
    throw std::invalid_argument("Sim3d::FromMatrix: 3x3 block has non-positive determinant");
  }
  const double s = std::cbrt(det);
  const Eigen::Matrix3d r = sr / s;
  CheckRotation(r, tol, "Sim3d::FromMatrix");
  const Eigen::Vector3d t = m.topRightCorner<3, 1>();
  if (!t.allFinite()) throw std::invalid_argument("Sim3d::FromMatrix: non-finite translation");
  return Sim3d(s, Eigen::Quaterniond(r), t);
}

Eigen::Matrix4d Sim3d::ToMatrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = scale * rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Sim3d Sim3d::Inverse() const {
  const Eigen::Quaterniond r_inv = rotation.conjugate();
  return Sim3d(1.0 / scale, r_inv, -(r_inv * translation) / scale);
}

Sim3d Sim3d::operator*(const Sim3d& o) const {
  return Sim3d(scale * o.scale, rotation * o.rotation, scale * (rotation * o.translation) + translation);
}

Rigid3d Sim3d::TransformCamera(const Rigid3d& cam_from_a) const {
  // Camera centre c_a moves to c_b = S * c_a; orientation world_from_cam rotates by R:
  // R_cam_from_b = R_cam_from_a * R^T, t = -R_cam_from_b * c_b.
  const Eigen::Vector3d center_a = -(cam_from_a.rotation.conjugate() * cam_from_a.translation);
  const Eigen::Vector3d center_b = (*this) * center_a;
  const Eigen::Quaterniond r = cam_from_a.rotation * rotation.conjugate();
  return Rigid3d(r, -(r * center_b));
}

double RotationErrorDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  const double d = std::abs(a.normalized().dot(b.normalized()));
  return 2.0 * std::acos(std::min(1.0, d)) * 180.0 / M_PI;
}

double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c = ((a.transpose() * b).trace() - 1.0) / 2.0;
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / M_PI;
}

double TranslationError(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).norm(); }

double DirectionAngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  if (a.norm() == 0 || b.norm() == 0) return 180.0;
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180 / M_PI;
}

Eigen::Quaterniond RandomRotation(double u1, double u2, double u3) {
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  return Eigen::Quaterniond(a * std::sin(2 * M_PI * u2), a * std::cos(2 * M_PI * u2), b * std::sin(2 * M_PI * u3),
                            b * std::cos(2 * M_PI * u3))
      .normalized();
}

}  // namespace nerfreg
