#include "nerfreg/render/trajectory.h"

#include <gtest/gtest.h>

#include "nerfreg/geometry/conventions.h"

namespace nerfreg {
namespace {

TEST(Trajectory, OrbitFollowsTheDRegNeRFRig) {
  const OrbitOptions o;
  const auto cams = OrbitTrajectory(o);
  ASSERT_EQ(cams.size(), 120u);
  const double deg = M_PI / 180;
  double min_el = 1e9, max_el = -1e9;
  for (int i = 0; i < 120; ++i) {
    const Eigen::Vector3d c = CameraCenter(cams[i].cam_from_world);
    EXPECT_NEAR(c.norm(), 4.0311, 1e-3);
    const double el = std::asin(c.z() / c.norm());
    double expected_el = std::atan2(0.5, 4.0);
    if (i > 0) expected_el += 0.7 * (std::cos(3.0 * (i - 1) * deg) + 1) / 2;
    EXPECT_NEAR(el, expected_el, 1e-9) << i;
    min_el = std::min(min_el, el);
    max_el = std::max(max_el, el);
    // Azimuth advances 6 degrees per view: two full turns.
    const double az = std::atan2(-c.x(), c.y());
    EXPECT_NEAR(std::remainder(az - 6.0 * i * deg, 2 * M_PI), 0.0, 1e-9) << i;
    // Every camera looks at the origin.
    const Eigen::Vector3d o_cam = cams[i].cam_from_world * Eigen::Vector3d::Zero();
    EXPECT_NEAR(o_cam.x(), 0, 1e-9);
    EXPECT_NEAR(o_cam.y(), 0, 1e-9);
  }
  EXPECT_NEAR(min_el / deg, 7.1, 0.1);  // "elevation oscillating ~7..47 deg"
  EXPECT_NEAR(max_el / deg, 47.2, 0.1);
  EXPECT_NEAR(cams[0].camera.FovX(), 0.6911112070083618, 1e-12);
}

TEST(Trajectory, ForwardCamerasAllLookAhead) {
  const auto cams = ForwardTrajectory(ForwardOptions{});
  ASSERT_EQ(cams.size(), 20u);
  for (const auto& c : cams) {
    const Eigen::Vector3d forward = c.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
    EXPECT_GT(forward.y(), 0.98);  // within ~11 degrees of +y
    EXPECT_NEAR(CameraCenter(c.cam_from_world).y(), -4.0, 1e-9);
  }
}

}  // namespace
}  // namespace nerfreg
