#include "nerfreg/geometry/rays.h"

namespace nerfreg {

Ray RayFromPixel(const Camera& camera, const Rigid3d& cam_from_world, const Eigen::Vector2d& uv) {
  const Eigen::Quaterniond world_from_cam = cam_from_world.rotation.conjugate();
  Ray ray;
  ray.origin = -(world_from_cam * cam_from_world.translation);
  ray.direction = (world_from_cam * camera.CamFromImg(uv)).normalized();
  return ray;
}

void GenerateRays(const Camera& camera, const Rigid3d& cam_from_world, Eigen::Matrix3Xd* origins,
                  Eigen::Matrix3Xd* directions, Eigen::VectorXd* z_dirs) {
  const int w = camera.width, h = camera.height;
  const Eigen::Matrix3d world_from_cam = cam_from_world.RotationMatrix().transpose();
  const Eigen::Vector3d center = -(world_from_cam * cam_from_world.translation);
  origins->resize(3, static_cast<Eigen::Index>(w) * h);
  directions->resize(3, static_cast<Eigen::Index>(w) * h);
  if (z_dirs) z_dirs->resize(static_cast<Eigen::Index>(w) * h);
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      const Eigen::Index i = static_cast<Eigen::Index>(row) * w + col;
      const Eigen::Vector3d d_cam = camera.CamFromImg({col + 0.5, row + 0.5}).normalized();
      origins->col(i) = center;
      directions->col(i) = world_from_cam * d_cam;
      if (z_dirs) (*z_dirs)(i) = d_cam.z();
    }
  }
}

}  // namespace nerfreg
