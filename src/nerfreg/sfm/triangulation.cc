#include "nerfreg/sfm/triangulation.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace nerfreg {

void TriangulationOptions::Check() const {
  if (!(max_reprojection_error_px > 0) || !(min_angle_deg >= 0))
    throw std::invalid_argument("TriangulationOptions: out of range");
}

bool TriangulateDlt(const std::vector<Rigid3d>& cam_from_world, const std::vector<Eigen::Vector3d>& x_normalized,
                    Eigen::Vector3d* x_in_world) {
  const int m = static_cast<int>(cam_from_world.size());
  if (m < 2 || static_cast<int>(x_normalized.size()) != m) return false;
  Eigen::MatrixXd a(2 * m, 4);
  for (int k = 0; k < m; ++k) {
    const Matrix3x4d p = cam_from_world[k].ToMatrix3x4();
    const Eigen::Vector3d& x = x_normalized[k];
    a.row(2 * k) = x.x() * p.row(2) - p.row(0);
    a.row(2 * k + 1) = x.y() * p.row(2) - p.row(1);
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (std::abs(h(3)) < 1e-12) return false;
  *x_in_world = h.head<3>() / h(3);
  return x_in_world->allFinite();
}

double ReprojectionErrorPx(const Camera& camera, const Rigid3d& cam_from_world, const Eigen::Vector3d& x_in_world,
                           const Eigen::Vector2d& uv) {
  const Eigen::Vector3d x = cam_from_world * x_in_world;
  if (!(x.z() > 1e-9)) return std::numeric_limits<double>::infinity();
  return (camera.ImgFromCam(x) - uv).norm();
}

bool TriangulateTrack(const Track& track, const std::vector<std::vector<Eigen::Vector2d>>& keypoints,
                      const std::vector<Camera>& cameras, const std::vector<Rigid3d>& cam_from_world,
                      const std::vector<bool>& posed, const TriangulationOptions& options, SfmPoint* point) {
  std::vector<TrackElement> elements;
  for (const auto& e : track.elements)
    if (posed[e.image]) elements.push_back(e);
  while (elements.size() >= 2) {
    std::vector<Rigid3d> poses;
    std::vector<Eigen::Vector3d> rays;
    for (const auto& e : elements) {
      poses.push_back(cam_from_world[e.image]);
      rays.push_back(cameras[e.image].CamFromImg(keypoints[e.image][e.keypoint]));
    }
    Eigen::Vector3d x;
    if (!TriangulateDlt(poses, rays, &x)) return false;
    int worst = -1;
    double worst_error = 0;
    for (size_t k = 0; k < elements.size(); ++k) {
      const auto& e = elements[k];
      const double error =
          ReprojectionErrorPx(cameras[e.image], cam_from_world[e.image], x, keypoints[e.image][e.keypoint]);
      if (error > worst_error) worst_error = error, worst = static_cast<int>(k);
    }
    if (worst_error > options.max_reprojection_error_px) {
      elements.erase(elements.begin() + worst);
      continue;
    }
    // Largest angle between two viewing rays (world frame), from the camera centres.
    double max_angle = 0;
    for (size_t a = 0; a < elements.size(); ++a) {
      const Eigen::Vector3d ra = x - cam_from_world[elements[a].image].Inverse().translation;
      for (size_t b = a + 1; b < elements.size(); ++b) {
        const Eigen::Vector3d rb = x - cam_from_world[elements[b].image].Inverse().translation;
        max_angle = std::max(max_angle, std::atan2(ra.cross(rb).norm(), ra.dot(rb)));
      }
    }
    if (max_angle * 180 / M_PI < options.min_angle_deg) return false;
    point->x_in_world = x;
    point->elements = elements;
    return true;
  }
  return false;
}

}  // namespace nerfreg
