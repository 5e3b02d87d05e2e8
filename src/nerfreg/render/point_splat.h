#pragma once
// Pictures of point clouds without a mesh: each point drawn as a small disc with a z-buffer, seen
// by a camera. Used for the before / after registration overlays.
#include <Eigen/Core>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

struct ColoredPoints {
  Eigen::Matrix3Xd xyz;   // [3, N]
  Eigen::Vector3f color;  // one colour for the cloud
};

// White background; nearer points win. radius in pixels.
Image SplatPoints(const std::vector<ColoredPoints>& clouds, const Camera& camera, const Rigid3d& cam_from_world,
                  int radius = 1);

// Three fixed views (front, side, top) of clouds centred at `centre`, `distance` away, tiled.
Image ThreeViewOverlay(const std::vector<ColoredPoints>& clouds, const Eigen::Vector3d& centre, double distance,
                       int size = 256);

}  // namespace nerfreg
