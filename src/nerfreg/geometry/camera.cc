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
  if (model == CameraModel::kOpenCVFisheye) {
    // Angle from the axis, so points beyond 90 degrees still map (fisheye lenses see them).
    const double rho = std::hypot(x.x(), x.y());
    if (rho < 1e-15) return {cx, cy};
    const double t = std::atan2(rho, x.z()), t2 = t * t;
    const double td = t * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
    return {fx * td * x.x() / rho + cx, fy * td * x.y() / rho + cy};
  }
  const double u = x.x() / x.z(), v = x.y() / x.z();
  double ud = u, vd = v;
  if (HasDistortion()) {
    const double r2 = u * u + v * v;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * (k3 + r2 * k4)));
    ud = u * radial + 2 * p1 * u * v + p2 * (r2 + 2 * u * u);
    vd = v * radial + p1 * (r2 + 2 * v * v) + 2 * p2 * u * v;
  }
  return {fx * ud + cx, fy * vd + cy};
}

Eigen::Vector3d Camera::CamFromImg(const Eigen::Vector2d& uv) const {
  const double ud = (uv.x() - cx) / fx, vd = (uv.y() - cy) / fy;
  if (model == CameraModel::kOpenCVFisheye) {
    const double td = std::hypot(ud, vd);
    if (td < 1e-15) return {0.0, 0.0, 1.0};
    // Newton on theta (1 + k1 theta^2 + ...) = theta_d, from theta = theta_d.
    double t = td;
    for (int it = 0; it < 30; ++it) {
      const double t2 = t * t;
      const double f = t * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - td;
      const double df = 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)));
      const double step = f / df;
      t -= step;
      if (std::abs(step) < 1e-15) break;
    }
    // A direction with z = 1 exists only in front of the camera.
    t = std::min(t, M_PI / 2 - 1e-9);
    const double r = std::tan(t);
    return {ud / td * r, vd / td * r, 1.0};
  }
  double u = ud, v = vd;
  if (HasDistortion()) {
    // Fixed-point iteration (as in OpenCV's undistortPoints); converges for moderate distortion.
    for (int it = 0; it < 50; ++it) {
      const double r2 = u * u + v * v;
      const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * (k3 + r2 * k4)));
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
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy) || !std::isfinite(cx) || !std::isfinite(cy) ||
      !std::isfinite(k1) || !std::isfinite(k2) || !std::isfinite(p1) || !std::isfinite(p2) || !std::isfinite(k3) ||
      !std::isfinite(k4)) {
    throw std::invalid_argument("Camera: focal lengths must be positive and finite: " + ToString());
  }
}

std::string Camera::ToString() const {
  std::ostringstream s;
  s << width << "x" << height << " f=(" << fx << "," << fy << ") c=(" << cx << "," << cy << ")";
  if (model == CameraModel::kOpenCVFisheye)
    s << " fisheye k=(" << k1 << "," << k2 << "," << k3 << "," << k4 << ")";
  else if (HasDistortion())
    s << " k=(" << k1 << "," << k2 << "," << p1 << "," << p2 << "," << k3 << "," << k4 << ")";
  return s.str();
}

}  // namespace nerfreg
