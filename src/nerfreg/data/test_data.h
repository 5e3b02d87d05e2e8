#pragma once
// Small datasets for the data layer's tests.
#include <random>

#include "nerfreg/data/dataset.h"
#include "nerfreg/geometry/conventions.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

// n cameras on a ring looking at the origin, with tiny PNGs written under root/images.
// centred: principal point at the image centre (all LLFF can store).
inline Dataset MakeRingDataset(const std::string& root, int n, bool distortion = false, bool centred = false) {
  Dataset d;
  d.root = root;
  for (int k = 0; k < n; ++k) {
    Frame f;
    f.name = "img_" + std::to_string(100 + k) + ".png";
    f.file_path = "images/" + f.name;
    f.camera = centred ? Camera::Pinhole(24, 16, 20, 20, 12, 8) : Camera::Pinhole(24, 16, 20, 20, 12.25, 7.75);
    if (distortion) {
      f.camera.k1 = -0.05;
      f.camera.p2 = 0.001;
    }
    const double a = 2 * M_PI * k / n;
    f.cam_from_world = LookAt({4 * std::cos(a), 4 * std::sin(a), 1.0 + 0.1 * k}, {0, 0, 0.2}, Eigen::Vector3d::UnitZ());
    f.split = k % 4 == 0 ? "test" : "train";
    f.near = 2.0;
    f.far = 6.0;
    WriteImage(d.ImagePath(f), Image(24, 16, 3, 0.25f * (k % 4)));
    d.frames.push_back(f);
  }
  return d;
}

inline void ExpectSamePoses(const Dataset& a, const Dataset& b, double tol = 1e-9) {
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t k = 0; k < a.frames.size(); ++k) {
    const Frame* fb = nullptr;
    for (const auto& f : b.frames)
      if (f.name == a.frames[k].name) fb = &f;
    ASSERT_NE(fb, nullptr) << a.frames[k].name;
    const Frame& fa = a.frames[k];
    EXPECT_LT((fa.cam_from_world.ToMatrix() - fb->cam_from_world.ToMatrix()).cwiseAbs().maxCoeff(), tol) << fa.name;
    EXPECT_NEAR(fa.camera.fx, fb->camera.fx, tol * 100);
    EXPECT_NEAR(fa.camera.fy, fb->camera.fy, tol * 100);
    EXPECT_NEAR(fa.camera.cx, fb->camera.cx, tol * 100);
    EXPECT_NEAR(fa.camera.cy, fb->camera.cy, tol * 100);
    EXPECT_EQ(fa.camera.width, fb->camera.width);
    EXPECT_EQ(fa.camera.height, fb->camera.height);
  }
}

}  // namespace nerfreg
