#pragma once
// An analytic scene for the learned core's tests and benchmarks, which have no render layer: a
// sphere of radius 0.6 at the origin, its colour varying with the normal, seen from `views`
// cameras on a sphere of radius 3 (golden-angle spiral). Writes size x size RGBA PNGs to `dir`
// (alpha 0 off the sphere); every 10th view is a test view.
#include <Eigen/Core>
#include <torch/torch.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>

#include "nerfreg/data/dataset.h"
#include "nerfreg/geometry/camera.h"
#include "nerfreg/nerf/nerf_block.h"  // CameraRays
#include "nerfreg/util/image.h"

namespace nerfreg {

inline Dataset SphereDataset(const std::string& dir, int views, int size) {
  std::filesystem::create_directories(dir);
  Dataset d;
  d.root = dir;
  d.aabb_min = Eigen::Vector3d::Constant(-0.7);
  d.aabb_max = Eigen::Vector3d::Constant(0.7);
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < views; ++i) {
    const double z = -0.8 + 1.6 * (i + 0.5) / views, r = std::sqrt(1 - z * z);
    const Eigen::Vector3d centre = 3.0 * Eigen::Vector3d(r * std::cos(golden * i), r * std::sin(golden * i), z);
    // OpenCV axes: z looks at the origin, x right, y down.
    const Eigen::Vector3d fwd = -centre.normalized();
    const Eigen::Vector3d right = fwd.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d down = fwd.cross(right);
    Eigen::Matrix3d world_from_cam;
    world_from_cam << right, down, fwd;
    Frame f;
    f.name = f.file_path = "r_" + std::to_string(i) + ".png";
    f.camera = Camera::FromFovX(size, size, 0.6);
    f.cam_from_world = Rigid3d(Eigen::Matrix3d(world_from_cam.transpose()), -world_from_cam.transpose() * centre);
    f.split = i % 10 == 5 ? "test" : "train";
    torch::Tensor o, dir_t;
    CameraRays(f.camera, f.cam_from_world, &o, &dir_t);  // [P, 3] each
    const auto b = (o * dir_t).sum(1), c = (o * o).sum(1) - 0.36;
    const auto disc = b * b - c;
    const auto hit = disc > 0;
    const auto t = -b - disc.clamp_min(0).sqrt();
    const auto normal = (o + dir_t * t.unsqueeze(1)) / 0.6;
    const auto rgb = (0.5 + 0.35 * normal + 0.1 * torch::sin(6 * normal.roll(1, 1))).clamp(0, 1);
    const auto rgba = torch::cat({rgb * hit.unsqueeze(1), hit.unsqueeze(1).to(torch::kFloat)}, 1).contiguous();
    Image im(size, size, 4);
    std::memcpy(im.data.data(), rgba.data_ptr<float>(), im.data.size() * sizeof(float));
    WriteImage(d.ImagePath(f), im);
    d.frames.push_back(f);
  }
  return d;
}

}  // namespace nerfreg
