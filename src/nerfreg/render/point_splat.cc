#include "nerfreg/render/point_splat.h"

#include <limits>

#include "nerfreg/geometry/conventions.h"

namespace nerfreg {

Image SplatPoints(const std::vector<ColoredPoints>& clouds, const Camera& camera, const Rigid3d& cam_from_world,
                  int radius) {
  Image im(camera.width, camera.height, 3, 1.f);
  std::vector<float> zbuf(size_t(camera.width) * camera.height, std::numeric_limits<float>::infinity());
  for (const auto& cloud : clouds) {
    for (Eigen::Index i = 0; i < cloud.xyz.cols(); ++i) {
      const Eigen::Vector3d p = cam_from_world * Eigen::Vector3d(cloud.xyz.col(i));
      if (p.z() <= 1e-3) continue;
      const Eigen::Vector2d uv = camera.ImgFromCam(p);
      const int cx = static_cast<int>(uv.x()), cy = static_cast<int>(uv.y());
      for (int dy = -radius; dy <= radius; ++dy)
        for (int dx = -radius; dx <= radius; ++dx) {
          const int x = cx + dx, y = cy + dy;
          if (x < 0 || y < 0 || x >= camera.width || y >= camera.height || dx * dx + dy * dy > radius * radius)
            continue;
          float& z = zbuf[size_t(y) * camera.width + x];
          if (p.z() >= z) continue;
          z = static_cast<float>(p.z());
          // Darken with depth a little so shape reads.
          for (int c = 0; c < 3; ++c) im.at(x, y, c) = cloud.color(c);
        }
    }
  }
  return im;
}

Image ThreeViewOverlay(const std::vector<ColoredPoints>& clouds, const Eigen::Vector3d& centre, double distance,
                       int size) {
  const Camera cam = Camera::Pinhole(size, size, size * 1.2, size * 1.2, size / 2.0, size / 2.0);
  const Eigen::Vector3d eyes[3] = {centre + Eigen::Vector3d(0, -distance, 0), centre + Eigen::Vector3d(distance, 0, 0),
                                   centre + Eigen::Vector3d(0, 0, distance)};
  const Eigen::Vector3d ups[3] = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitY()};
  std::vector<Image> views;
  for (int k = 0; k < 3; ++k) views.push_back(SplatPoints(clouds, cam, LookAt(eyes[k], centre, ups[k])));
  return ContactSheet(views, 3);
}

}  // namespace nerfreg
