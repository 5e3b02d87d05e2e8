#include "nerfreg/geometry/camera.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace nerfreg {

Camera Camera::Pinhole(int width, int height, double fx, double fy, double cx, double cy) {
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = fx;
  c.fy = fy;
  c.cx = cx;
  c.cy = cy;
  return c;
}

Camera Camera::FromFovX(int width, int height, double camera_angle_x) {
  const double f = 0.5 * width / std::tan(0.5 * camera_angle_x);
  return Pinhole(width, height, f, f, 0.5 * width, 0.5 * height);
}

double Camera::FovX() const { return 2.0 * std::atan(0.5 * width / fx); }
double Camera::FovY() const { return 2.0 * std::atan(0.5 * height / fy); }

Eigen::Vector2d Camera::ImgFromCam(const Eigen::Vector3d& x) const {
  const double u = x.x() / x.z(), v = x.y() / x.z();
  double ud = u, vd = v;
  if (HasDistortion()) {
    const double r2 = u * u + v * v;
    const double radial = 1 + k1 * r2 + k2 * r2 * r2;
    ud = u * radial + 2 * p1 * u * v + p2 * (r2 + 2 * u * u);
    vd = v * radial + p1 * (r2 + 2 * v * v) + 2 * p2 * u * v;
  }
  return {fx * ud + cx, fy * vd + cy};
}

Eigen::Vector3d Camera::CamFromImg(const Eigen::Vector2d& uv) const {
  const double ud = (uv.x() - cx) / fx, vd = (uv.y() - cy) / fy;
  double u = ud, v = vd;
  if (HasDistortion()) {
    // Fixed-point iteration (as in OpenCV's undistortPoints); converges for moderate distortion.
    for (int it = 0; it < 50; ++it) {
      const double r2 = u * u + v * v;
      const double radial = 1 + k1 * r2 + k2 * r2 * r2;
      const double du = 2 * p1 * u * v + p2 * (r2 + 2 * u * u);
      const double dv = p1 * (r2 + 2 * v * v) + 2 * p2 * u * v;
      const double nu = (ud - du) / radial, nv = (vd - dv) / radial;
      const bool done = std::abs(nu - u) < 1e-14 && std::abs(nv - v) < 1e-14;
      u = nu;
      v = nv;
      if (done) break;
    }
  }
  return {u, v, 1.0};
}

Camera Camera::Resized(int new_width, int new_height) const {
  Camera c = *this;
  const double sx = double(new_width) / width, sy = double(new_height) / height;
  c.width = new_width;
  c.height = new_height;
  c.fx *= sx;
  c.cx *= sx;
  c.fy *= sy;
  c.cy *= sy;
  return c;
}

void Camera::Check() const {
  if (width <= 0 || height <= 0) throw std::invalid_argument("Camera: size must be positive: " + ToString());
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy) || !std::isfinite(cx) ||
      !std::isfinite(cy) || !std::isfinite(k1) || !std::isfinite(k2) || !std::isfinite(p1) ||
      !std::isfinite(p2)) {
    throw std::invalid_argument("Camera: focal lengths must be positive and finite: " + ToString());
  }
}

std::string Camera::ToString() const {
  std::ostringstream s;
  s << width << "x" << height << " f=(" << fx << "," << fy << ") c=(" << cx << "," << cy << ")";
  if (HasDistortion()) s << " k=(" << k1 << "," << k2 << "," << p1 << "," << p2 << ")";
  return s.str();
}

}  // namespace nerfreg
