// Tests only: an analytic scene, one textured plane seen by pinhole cameras, rendered exactly (no
// sampling of a texture image), with its true inverse depth and relative poses.
#pragma once

#include <torch/torch.h>

#include "nerfreg/util/torch_device.h"  // torch::linalg under LibTorch 2.x
#include "nerfreg/dbarf/inverse_warp.h"
#include "nerfreg/dbarf/se3.h"

namespace nerfreg {
namespace testing_scene {

// The plane {x_in_tgt : normal . x_in_tgt = offset}, expressed in the target camera's frame; with
// a second plane (Ridge), the solid behind both planes, whose visible surface is the later of the
// two ray-plane intersections (a convex ridge, no occlusion for moderate viewpoint changes).
struct PlaneScene {
  int64_t height = 48;
  int64_t width = 64;
  torch::Tensor intrinsics;  // [3, 3] float32
  torch::Tensor normal;      // [3] float32, unit
  double offset = 2.0;       // distance along the normal
  torch::Tensor normal2;     // [3] float32, unit; undefined for a single plane
  double offset2 = 0.0;

  static PlaneScene FrontoParallel(double depth, int64_t height = 48, int64_t width = 64) {
    PlaneScene s;
    s.height = height;
    s.width = width;
    const double f = 0.9 * static_cast<double>(width);
    s.intrinsics =
        torch::tensor({f, 0.0, width / 2.0, 0.0, f, height / 2.0, 0.0, 0.0, 1.0}, torch::kFloat).view({3, 3});
    s.normal = torch::tensor({0.0f, 0.0f, 1.0f});
    s.offset = depth;
    return s;
  }
  static PlaneScene Tilted(double depth, int64_t height = 48, int64_t width = 64) {
    PlaneScene s = FrontoParallel(depth, height, width);
    s.normal = torch::tensor({0.25f, -0.15f, 1.0f});
    s.normal = s.normal / s.normal.norm();
    s.offset = depth * s.normal[2].item<double>();
    return s;
  }

  // Two faces through (0, 0, depth) tilted by +-slope in x: depth = depth + slope * |x| (and a
  // little y tilt), so the scene has depth variation that planes lack.
  static PlaneScene Ridge(double depth, double slope = 0.4, int64_t height = 48, int64_t width = 64) {
    PlaneScene s = FrontoParallel(depth, height, width);
    s.normal = torch::tensor({static_cast<float>(-slope), 0.1f, 1.0f});
    s.normal = s.normal / s.normal.norm();
    s.offset = depth * s.normal[2].item<double>();
    s.normal2 = torch::tensor({static_cast<float>(slope), 0.1f, 1.0f});
    s.normal2 = s.normal2 / s.normal2.norm();
    s.offset2 = depth * s.normal2[2].item<double>();
    return s;
  }

  // Smooth colour texture at plane points x_in_tgt [P, 3] -> [P, 3] in about [0.05, 0.95].
  static torch::Tensor Texture(const torch::Tensor& x) {
    const torch::Tensor a = x.select(1, 0), b = x.select(1, 1), c = x.select(1, 2);
    const torch::Tensor r = 0.5 + 0.25 * torch::sin(5.0 * a + 1.0) + 0.15 * torch::cos(7.0 * b - 3.0 * a);
    const torch::Tensor g = 0.5 + 0.2 * torch::sin(6.0 * b + 2.0 * a) + 0.2 * torch::cos(4.0 * a + 0.5);
    const torch::Tensor bl = 0.5 + 0.3 * torch::sin(3.0 * a - 4.0 * b + 0.3 * c) + 0.1 * torch::sin(9.0 * a);
    return torch::stack({r, g, bl}, 1);
  }

  // Renders the camera cam_from_tgt [4, 4] -> image [1, 3, H, W] float32.
  torch::Tensor Render(const torch::Tensor& cam_from_tgt) const {
    const torch::Tensor tgt_from_cam = Se3Inverse(cam_from_tgt.to(torch::kFloat));
    const torch::Tensor r = tgt_from_cam.slice(0, 0, 3).slice(1, 0, 3);
    const torch::Tensor o = tgt_from_cam.slice(0, 0, 3).select(1, 3);
    const torch::Tensor pix = PixelCentres(height, width, torch::kFloat);
    const torch::Tensor dirs = torch::matmul(torch::matmul(pix, torch::linalg::inv(intrinsics).t()), r.t());
    torch::Tensor s = (offset - torch::dot(normal, o)) / torch::matmul(dirs, normal);
    if (normal2.defined()) s = torch::maximum(s, (offset2 - torch::dot(normal2, o)) / torch::matmul(dirs, normal2));
    const torch::Tensor x = o + s.unsqueeze(1) * dirs;
    return Texture(x).t().reshape({1, 3, height, width}).contiguous();
  }

  // The target camera's true inverse depth [1, 1, H, W].
  torch::Tensor TargetInverseDepth() const {
    const torch::Tensor pix = PixelCentres(height, width, torch::kFloat);
    const torch::Tensor rays = torch::matmul(pix, torch::linalg::inv(intrinsics).t());  // z = 1
    torch::Tensor inv = torch::matmul(rays, normal) / offset;
    if (normal2.defined()) inv = torch::minimum(inv, torch::matmul(rays, normal2) / offset2);
    return inv.view({1, 1, height, width});
  }
};

// A few relative poses src_from_tgt [N, 4, 4] with a visible baseline (N <= 3).
inline torch::Tensor SourcePoses(int64_t n) {
  const torch::Tensor xi = torch::tensor({{0.15, -0.05, 0.03, 0.02, -0.04, 0.03},
                                          {-0.12, 0.08, -0.05, -0.03, 0.05, -0.02},
                                          {0.05, 0.12, 0.08, 0.04, 0.02, 0.05}},
                                         torch::kFloat);
  return Se3Exp(xi.slice(0, 0, n));
}

}  // namespace testing_scene
}  // namespace nerfreg
