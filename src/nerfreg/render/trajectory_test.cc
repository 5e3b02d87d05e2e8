#include "nerfreg/render/trajectory.h"

#include <gtest/gtest.h>

#include <Eigen/SVD>

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

// The LLFF-like capture: optical axes within a few degrees of +y (so of each other), centres in a
// plane whose normal is the axes' direction, an extent that is the spread's, and a real wobble
// (not a pure translation); the path depends on the seed alone.
TEST(Trajectory, HandheldCamerasHaveParallelAxesAndCentresInAPlane) {
  HandheldOptions o;
  o.seed = 11;
  const auto cams = HandheldTrajectory(o);
  ASSERT_EQ(cams.size(), 20u);
  const double deg = M_PI / 180;
  std::vector<Eigen::Vector3d> axes, centres;
  for (const auto& c : cams) {
    axes.push_back(c.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ());
    centres.push_back(CameraCenter(c.cam_from_world));
    EXPECT_LT(std::acos(std::min(1.0, axes.back().y())), 1.5 * o.max_rotation_deg * deg);
    // The image's up stays near +z (a roll of a degree or two at most).
    const Eigen::Vector3d up = c.cam_from_world.rotation.conjugate() * -Eigen::Vector3d::UnitY();
    EXPECT_GT(up.z(), std::cos(2 * o.max_rotation_deg * deg));
  }
  double max_pair_deg = 0;
  for (size_t i = 0; i < axes.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      max_pair_deg = std::max(max_pair_deg, std::acos(std::min(1.0, axes[i].dot(axes[j]))) / deg);
  EXPECT_LT(max_pair_deg, 3 * o.max_rotation_deg);  // a few degrees
  EXPECT_GT(max_pair_deg, 1.0);                     // but the hand does turn
  // Plane fit: the centres' smallest principal extent is the out-of-plane wobble, its normal +y.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : centres) mean += c / centres.size();
  Eigen::MatrixXd a(centres.size(), 3);
  for (size_t i = 0; i < centres.size(); ++i) a.row(i) = (centres[i] - mean).transpose();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinV);
  const Eigen::Vector3d normal = svd.matrixV().col(2);
  EXPECT_GT(std::abs(normal.y()), std::cos(5 * deg));
  double max_off = 0, min_x = 1e9, max_x = -1e9, min_z = 1e9, max_z = -1e9;
  for (const auto& c : centres) {
    max_off = std::max(max_off, std::abs(normal.dot(c - mean)));
    min_x = std::min(min_x, c.x()), max_x = std::max(max_x, c.x());
    min_z = std::min(min_z, c.z()), max_z = std::max(max_z, c.z());
    EXPECT_NEAR(c.y(), -o.distance, o.depth_wobble * o.spread + 1e-9);
  }
  EXPECT_LE(max_off, 2 * o.depth_wobble * o.spread);  // the fit passes through the mean, the wobble is +-
  EXPECT_GT(max_x - min_x, 1.4 * o.spread);           // the path sweeps the plane, not a line
  EXPECT_LE(max_x - min_x, 2 * o.spread + 1e-9);
  EXPECT_GT(max_z - min_z, 0.75 * 1.4 * o.spread);
  // Neighbouring views are close: a hand-held sweep, not jumps.
  for (size_t i = 1; i < centres.size(); ++i) EXPECT_LT((centres[i] - centres[i - 1]).norm(), 0.7 * o.spread) << i;
  // Deterministic in the seed; another seed, another path.
  const auto again = HandheldTrajectory(o);
  for (size_t i = 0; i < cams.size(); ++i)
    EXPECT_EQ(again[i].cam_from_world.ToMatrix(), cams[i].cam_from_world.ToMatrix()) << i;
  o.seed = 12;
  EXPECT_GT((CameraCenter(HandheldTrajectory(o)[0].cam_from_world) - centres[0]).norm(), 1e-3);
}

// The room walk: centres on the ellipse at eye height, one loop; the heading swings, so the set
// holds views towards the room's centre and views towards the walls; seeded.
TEST(Trajectory, RoomWalkLooksInwardAndOutward) {
  RoomWalkOptions o;
  o.seed = 3;
  const auto cams = RoomWalkTrajectory(o);
  ASSERT_EQ(cams.size(), 30u);
  int inward = 0, outward = 0;
  for (const auto& c : cams) {
    const Eigen::Vector3d centre = CameraCenter(c.cam_from_world);
    EXPECT_NEAR(std::pow(centre.x() / o.radius_x, 2) + std::pow(centre.y() / o.radius_y, 2), 1.0, 1e-9);
    EXPECT_NEAR(centre.z(), o.eye_height, 1e-9);
    const Eigen::Vector3d axis = c.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
    EXPECT_LT(axis.z(), 0.0);  // looking slightly down
    EXPECT_GT(axis.z(), -std::sin(12 * M_PI / 180));
    const Eigen::Vector3d to_centre = Eigen::Vector3d(-centre.x(), -centre.y(), 0).normalized();
    const double c_in = axis.dot(to_centre) / Eigen::Vector3d(axis.x(), axis.y(), 0).norm();
    inward += c_in > 0.5;    // within 60 deg of the centre
    outward += c_in < -0.5;  // within 60 deg of straight out
  }
  EXPECT_GE(inward, 4);
  EXPECT_GE(outward, 4);
  const auto again = RoomWalkTrajectory(o);
  for (size_t i = 0; i < cams.size(); ++i)
    EXPECT_EQ(again[i].cam_from_world.ToMatrix(), cams[i].cam_from_world.ToMatrix()) << i;
}

}  // namespace
}  // namespace nerfreg
