#include "nerfreg/render/camera_plot.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace nerfreg {
namespace {

void Pixel(Image* im, int x, int y, const Eigen::Vector3f& color) {
  if (x < 0 || y < 0 || x >= im->width || y >= im->height) return;
  for (int c = 0; c < 3; ++c) im->at(x, y, c) = color(c);
}

void Disc(Image* im, double cx, double cy, int radius, const Eigen::Vector3f& color) {
  const int x0 = static_cast<int>(std::lround(cx)), y0 = static_cast<int>(std::lround(cy));
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx)
      if (dx * dx + dy * dy <= radius * radius) Pixel(im, x0 + dx, y0 + dy, color);
}

// A line `half_width` pixels either side (0: one pixel wide).
void Line(Image* im, double x0, double y0, double x1, double y1, int half_width, const Eigen::Vector3f& color) {
  const int steps = std::max(1, static_cast<int>(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))));
  // Centres far outside the picture cannot happen (they are fitted into it); the bound keeps a
  // NaN or a huge value from looping for long anyway.
  if (steps > 4 * (im->width + im->height)) return;
  for (int i = 0; i <= steps; ++i) {
    const double t = double(i) / steps;
    const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0))),
              y = static_cast<int>(std::lround(y0 + t * (y1 - y0)));
    for (int dy = -half_width; dy <= half_width; ++dy)
      for (int dx = -half_width; dx <= half_width; ++dx) Pixel(im, x + dx, y + dy, color);
  }
}

Eigen::Vector3d CenterOf(const Rigid3d& cam_from_world) {
  return -(cam_from_world.rotation.conjugate() * cam_from_world.translation);
}
// OpenCV camera axes: the camera looks along +z, its up is -y.
Eigen::Vector3d ViewDirection(const Rigid3d& cam_from_world) {
  return cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
}
Eigen::Vector3d UpDirection(const Rigid3d& cam_from_world) {
  return cam_from_world.rotation.conjugate() * -Eigen::Vector3d::UnitY();
}

// The normal of the view plane: the mean up of `cams`, or, when they disagree (mean shorter than
// 0.5), the normal of the centres' best-fit plane on the side of the mean up.
Eigen::Vector3d PlaneNormal(const std::vector<Rigid3d>& cams) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero(), mean = Eigen::Vector3d::Zero();
  for (const Rigid3d& c : cams) up += UpDirection(c), mean += CenterOf(c);
  up /= double(cams.size());
  mean /= double(cams.size());
  if (up.norm() >= 0.5) return up.normalized();
  if (cams.size() >= 3) {
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const Rigid3d& c : cams) cov += (CenterOf(c) - mean) * (CenterOf(c) - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    Eigen::Vector3d n = eig.eigenvectors().col(0);  // smallest eigenvalue first
    // Only a plane, not a line or a point, defines a normal.
    if (eig.eigenvalues()(1) > 1e-12 * std::max(1.0, eig.eigenvalues()(2))) return up.dot(n) < 0 ? -n : n;
  }
  return up.norm() > 1e-9 ? up.normalized() : Eigen::Vector3d::UnitZ();
}

// 1, 2 or 5 x 10^k, the largest not above `target` (> 0).
double NiceLength(double target) {
  const double p = std::pow(10.0, std::floor(std::log10(target)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= target) return m * p;
  return p;
}

}  // namespace

void CameraPlotOptions::Check() const {
  if (size < 64 || size > 8192) throw std::invalid_argument("size: expected 64 to 8192 pixels");
  if (margin < 8 || 2 * margin > size / 2)
    throw std::invalid_argument("margin: expected 8 pixels to a quarter of size");
  if (marker_radius < 1 || marker_radius > size / 16)
    throw std::invalid_argument("marker_radius: expected 1 to size / 16");
  if (!(direction_length >= 0 && direction_length <= 1))
    throw std::invalid_argument("direction_length: expected 0 to 1");
}

CameraPlot PlotCamerasFromAbove(const std::vector<PlottedCameras>& sets, bool link_first_two,
                                const CameraPlotOptions& options) {
  options.Check();
  if (sets.empty() || sets[0].cam_from_world.empty()) throw std::invalid_argument("PlotCamerasFromAbove: no cameras");
  if (link_first_two && (sets.size() < 2 || sets[0].cam_from_world.size() != sets[1].cam_from_world.size())) {
    throw std::invalid_argument("PlotCamerasFromAbove: linked sets must have the same number of cameras");
  }
  // The view frame: normal n (towards the viewer), forward = the mean viewing direction in the
  // plane (up the picture), right = forward x n.
  const Eigen::Vector3d n = PlaneNormal(sets[0].cam_from_world);
  Eigen::Vector3d forward = Eigen::Vector3d::Zero();
  for (const Rigid3d& c : sets[0].cam_from_world) forward += ViewDirection(c);
  forward -= forward.dot(n) * n;
  if (forward.norm() < 1e-6) forward = n.unitOrthogonal();
  forward.normalize();
  const Eigen::Vector3d right = forward.cross(n);
  auto project = [&](const Eigen::Vector3d& x) { return Eigen::Vector2d(x.dot(right), x.dot(forward)); };

  Eigen::Vector2d lo = Eigen::Vector2d::Constant(INFINITY), hi = Eigen::Vector2d::Constant(-INFINITY);
  for (const auto& set : sets)
    for (const Rigid3d& c : set.cam_from_world) {
      const Eigen::Vector2d p = project(CenterOf(c));
      lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    }
  if (!lo.allFinite() || !hi.allFinite())
    throw std::invalid_argument("PlotCamerasFromAbove: non-finite camera centres");
  double extent = (hi - lo).maxCoeff();
  if (!(extent > 0)) extent = 1;  // one camera, or all at one point
  const double usable = options.size - 2.0 * options.margin;
  const double pixels_per_unit = usable / extent;
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  auto to_image = [&](const Eigen::Vector3d& x, double* u, double* v) {
    const Eigen::Vector2d p = project(x) - mid;
    *u = 0.5 * options.size + p.x() * pixels_per_unit;
    *v = 0.5 * options.size - p.y() * pixels_per_unit;
  };

  CameraPlot plot;
  plot.image = Image(options.size, options.size, 3, 1.f);
  Image* im = &plot.image;
  if (link_first_two) {
    for (size_t k = 0; k < sets[0].cam_from_world.size(); ++k) {
      double u0, v0, u1, v1;
      to_image(CenterOf(sets[0].cam_from_world[k]), &u0, &v0);
      to_image(CenterOf(sets[1].cam_from_world[k]), &u1, &v1);
      Line(im, u0, v0, u1, v1, 0, kLinkColor);
    }
  }
  // The first set last, on top.
  for (size_t s = sets.size(); s-- > 0;) {
    for (const Rigid3d& c : sets[s].cam_from_world) {
      double u, v, du, dv;
      to_image(CenterOf(c), &u, &v);
      to_image(CenterOf(c) + options.direction_length * extent * ViewDirection(c), &du, &dv);
      Line(im, u, v, du, dv, 0, sets[s].color);
      Disc(im, u, v, options.marker_radius, sets[s].color);
    }
  }
  // Scale bar, with end ticks, in the bottom margin.
  plot.scale_bar_length = NiceLength(0.25 * extent);
  const double bar_px = plot.scale_bar_length * pixels_per_unit;
  const double y = options.size - 0.5 * options.margin, x0 = options.margin;
  const Eigen::Vector3f black(0, 0, 0);
  Line(im, x0, y, x0 + bar_px, y, 1, black);
  Line(im, x0, y - 4, x0, y + 4, 0, black);
  Line(im, x0 + bar_px, y - 4, x0 + bar_px, y + 4, 0, black);
  return plot;
}

}  // namespace nerfreg
