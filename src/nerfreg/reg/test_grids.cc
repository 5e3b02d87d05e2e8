#include "nerfreg/reg/test_grids.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace nerfreg {
namespace {

struct Primitive {
  bool is_box;
  Eigen::Vector3d centre;
  Eigen::Vector3d size;  // radius in x for spheres, half extents for boxes
  Eigen::Vector3d colour;
  double Sdf(const Eigen::Vector3d& p) const {
    if (!is_box) return (p - centre).norm() - size.x();
    const Eigen::Vector3d q = (p - centre).cwiseAbs() - size;
    return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  }
};

const std::vector<Primitive>& Shape() {
  static const std::vector<Primitive> shape = {
      {false, {0.5, 0.0, 0.0}, {0.35, 0, 0}, {0.9, 0.1, 0.1}},
      {false, {-0.3, 0.45, 0.1}, {0.3, 0, 0}, {0.1, 0.8, 0.2}},
      {false, {-0.2, -0.3, 0.45}, {0.25, 0, 0}, {0.1, 0.2, 0.9}},
      {true, {0.0, 0.0, -0.3}, {0.55, 0.15, 0.15}, {0.9, 0.8, 0.1}},
  };
  return shape;
}

}  // namespace

RegGrid MakeShapeGrid(int resolution, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                      uint64_t seed, double jitter_cells) {
  const int d = resolution;
  RegGrid g;
  g.source = "mesh";
  g.rgba = torch::zeros({4, d, d, d});
  g.xyz = torch::zeros({d, d, d, 3});
  g.surface = torch::zeros({d, d, d});
  g.mask = torch::zeros({d, d, d}, torch::kBool);
  const double cell = g.CellSize();
  auto rgba = g.rgba.accessor<float, 4>();
  auto xyz = g.xyz.accessor<float, 4>();
  auto surface = g.surface.accessor<float, 3>();
  auto mask = g.mask.accessor<bool, 3>();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.5 * jitter_cells * cell, 0.5 * jitter_cells * cell);
  for (int i = 0; i < d; ++i) {
    for (int j = 0; j < d; ++j) {
      for (int k = 0; k < d; ++k) {
        Eigen::Vector3d p = g.aabb_min + (Eigen::Vector3d(i, j, k) + Eigen::Vector3d::Constant(0.5)) * cell;
        p += Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
        const Eigen::Vector3d x = rotation.transpose() * (p - translation);
        double sdf = 1e9;
        const Primitive* nearest = nullptr;
        for (const Primitive& prim : Shape()) {
          const double s = prim.Sdf(x);
          if (s < sdf) {
            sdf = s;
            nearest = &prim;
          }
        }
        for (int c = 0; c < 3; ++c) xyz[i][j][k][c] = static_cast<float>(p[c]);
        const double s = std::clamp(1.0 - std::abs(sdf) / (1.5 * cell), 0.0, 1.0);
        surface[i][j][k] = static_cast<float>(s);
        if (sdf < 0.0) {
          for (int c = 0; c < 3; ++c) rgba[c][i][j][k] = static_cast<float>(nearest->colour[c]);
          rgba[3][i][j][k] = 0.9f;
          mask[i][j][k] = s >= 0.5;
        }
      }
    }
  }
  return g;
}

torch::Tensor RigidMatrix(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  torch::Tensor m = torch::eye(4);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[i][j] = rotation(i, j);
    m[i][3] = translation[i];
  }
  return m;
}

double RotationErrorDeg(const torch::Tensor& a, const torch::Tensor& b) {
  const double tr = torch::trace(torch::matmul(a.to(torch::kDouble).t(), b.to(torch::kDouble))).item<double>();
  return std::acos(std::clamp((tr - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / 3.14159265358979323846;
}

}  // namespace nerfreg
