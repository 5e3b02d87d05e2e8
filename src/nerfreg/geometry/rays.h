#pragma once
// Ray generation: one ray per pixel centre (col + 0.5, row + 0.5), in world coordinates.
#include <Eigen/Core>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;  // unit length, world frame
};

// Ray through image point uv (continuous coordinates, camera.h).
Ray RayFromPixel(const Camera& camera, const Rigid3d& cam_from_world, const Eigen::Vector2d& uv);

// All rays of an image, row-major: index = row * width + col.
// directions and origins: [3, H*W]. `z_dirs` (optional, may be null): the z (forward) component
// of each ray's unit direction in the camera frame, to turn ray distance into z-depth.
void GenerateRays(const Camera& camera, const Rigid3d& cam_from_world, Eigen::Matrix3Xd* origins,
                  Eigen::Matrix3Xd* directions, Eigen::VectorXd* z_dirs = nullptr);

}  // namespace nerfreg
