// Test-only RegGrid factory: an analytic, asymmetric shape (a union of coloured spheres and a
// box) voxelised into a RegGrid as a NeRF block would see it, in a frame moved by a rigid
// transform. Lets reg tests build grid pairs with a known target_from_source without the grid
// extraction code.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "nerfreg/reg/reg_grid.h"

namespace nerfreg {

// The shape's points x are placed at x_in_grid = rotation * x + translation. Per voxel, the sample
// point is the voxel centre plus uniform jitter (+- jitter_cells / 2 cells, seeded); the
// signed distance to the shape there gives: rgba = (colour of the nearest primitive, 0.9) inside,
// 0 outside; surface S = clamp(1 - |sdf| / (1.5 cell), 0, 1); mask = inside AND S >= 0.5 (a shell
// about one voxel thick). The shape fits in a ball of radius 0.95 around the origin.
RegGrid MakeShapeGrid(int resolution, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                      uint64_t seed = 1, double jitter_cells = 0.5);

// A 4x4 float32 tensor [R t; 0 1].
torch::Tensor RigidMatrix(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

// Geodesic angle between two rotations [3, 3] (any float dtype), degrees.
double RotationErrorDeg(const torch::Tensor& a, const torch::Tensor& b);

}  // namespace nerfreg
