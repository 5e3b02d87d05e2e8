#include "nerfreg/render/trajectory.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <stdexcept>

#include "nerfreg/geometry/conventions.h"

namespace nerfreg {

void OrbitOptions::Check() const {
  if (num_views < 1 || width < 1 || height < 1 || !(camera_angle_x > 0 && camera_angle_x < M_PI) || !(radius > 0)) {
    throw std::invalid_argument("OrbitOptions: out of range");
  }
}

void ForwardOptions::Check() const {
  if (num_views < 1 || width < 1 || height < 1 || !(focal_factor > 0) || !(distance > 0) || spread < 0) {
    throw std::invalid_argument("ForwardOptions: out of range");
  }
}

void HandheldOptions::Check() const {
  if (num_views < 1 || width < 1 || height < 1 || !(focal_factor > 0) || !(distance > 0) || !(spread >= 0) ||
      !(depth_wobble >= 0) || !(max_rotation_deg >= 0 && max_rotation_deg < 45)) {
    throw std::invalid_argument("HandheldOptions: out of range");
  }
}

void RoomWalkOptions::Check() const {
  if (num_views < 1 || width < 1 || height < 1 || !(focal_factor > 0) || !(radius_x > 0) || !(radius_y > 0) ||
      !(swing_deg >= 0 && swing_deg <= 180) || !(std::abs(pitch_deg) < 80) || !(wobble_deg >= 0 && wobble_deg < 10)) {
    throw std::invalid_argument("RoomWalkOptions: out of range");
  }
}

void OrbitAngles(const OrbitOptions& o, int i, double* elevation, double* azimuth) {
  const double deg = M_PI / 180.0;
  const double tilt = i == 0 ? 0.0 : o.max_tilt * (std::cos(o.tilt_period_step_deg * (i - 1) * deg) + 1.0) / 2.0;
  *elevation = o.base_elevation + tilt;
  *azimuth = o.azimuth_step_deg * i * deg;
}

std::vector<PosedCamera> OrbitTrajectory(const OrbitOptions& o) {
  o.Check();
  std::vector<PosedCamera> out;
  const Camera camera = Camera::FromFovX(o.width, o.height, o.camera_angle_x);
  for (int i = 0; i < o.num_views; ++i) {
    double el, az;
    OrbitAngles(o, i, &el, &az);
    // Azimuth measured from the +y axis (the rig's start at (0, 4, 0.5)), counter-clockwise.
    const Eigen::Vector3d eye(-o.radius * std::cos(el) * std::sin(az), o.radius * std::cos(el) * std::cos(az),
                              o.radius * std::sin(el));
    out.push_back({camera, LookAt(eye, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ())});
  }
  return out;
}

std::vector<PosedCamera> ForwardTrajectory(const ForwardOptions& o) {
  o.Check();
  std::vector<PosedCamera> out;
  const double f = o.focal_factor * o.width;
  const Camera camera = Camera::Pinhole(o.width, o.height, f, f, 0.5 * o.width, 0.5 * o.height);
  for (int i = 0; i < o.num_views; ++i) {
    // Two turns of a spiral whose radius grows from 0.3 to 1 of the spread.
    const double t = o.num_views > 1 ? double(i) / (o.num_views - 1) : 0.0;
    const double angle = 4 * M_PI * t;
    const double r = o.spread * (0.3 + 0.7 * t);
    const Eigen::Vector3d eye(r * std::cos(angle), -o.distance, r * std::sin(angle) * 0.75);
    // Look at a point straight ahead, slightly pulled to the centre: forward-facing, converging.
    const Eigen::Vector3d target(0.3 * eye.x(), -o.distance + o.look_depth, 0.3 * eye.z());
    out.push_back({camera, LookAt(eye, target, Eigen::Vector3d::UnitZ())});
  }
  return out;
}

std::vector<PosedCamera> HandheldTrajectory(const HandheldOptions& o) {
  o.Check();
  std::mt19937 rng(o.seed * 2654435761u + 7u);
  std::uniform_real_distribution<double> phase(0, 2 * M_PI);
  double p[7];
  for (double& x : p) x = phase(rng);
  const double f = o.focal_factor * o.width;
  const Camera camera = Camera::Pinhole(o.width, o.height, f, f, 0.5 * o.width, 0.5 * o.height);
  const double amplitude = o.max_rotation_deg * M_PI / 180;
  std::vector<PosedCamera> out;
  for (int i = 0; i < o.num_views; ++i) {
    const double t = o.num_views > 1 ? double(i) / (o.num_views - 1) : 0.0;
    const Eigen::Vector3d eye(o.spread * std::sin(2 * M_PI * t + p[0]),
                              -o.distance + o.depth_wobble * o.spread * std::sin(6 * M_PI * t + p[1]),
                              0.75 * o.spread * std::sin(4 * M_PI * t + p[2]));
    // Axes parallel to +y, then the wobble about the camera's own axes (OpenCV: x right, y down).
    const Rigid3d level = LookAt(eye, eye + Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ());
    const double yaw = amplitude * std::sin(3 * M_PI * t + p[3]);
    const double pitch = amplitude * std::sin(2.6 * M_PI * t + p[4]);
    const double roll = 0.5 * amplitude * std::sin(2.2 * M_PI * t + p[5]);
    const Eigen::Quaterniond wobble = Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()) *
                                      Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
                                      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY());
    Rigid3d cam_from_world = level;
    cam_from_world.rotation = wobble * level.rotation;
    cam_from_world.translation = -(cam_from_world.rotation * eye);
    out.push_back({camera, cam_from_world});
  }
  return out;
}

std::vector<PosedCamera> RoomWalkTrajectory(const RoomWalkOptions& o) {
  o.Check();
  std::mt19937 rng(o.seed * 2654435761u + 13u);
  std::uniform_real_distribution<double> phase(0, 2 * M_PI);
  double p[4];
  for (double& x : p) x = phase(rng);
  const double f = o.focal_factor * o.width;
  const Camera camera = Camera::Pinhole(o.width, o.height, f, f, 0.5 * o.width, 0.5 * o.height);
  const double deg = M_PI / 180;
  std::vector<PosedCamera> out;
  for (int i = 0; i < o.num_views; ++i) {
    // One loop, counter-clockwise, not closing on the first view.
    const double a = 2 * M_PI * i / o.num_views + p[0];
    const Eigen::Vector3d eye(o.radius_x * std::cos(a), o.radius_y * std::sin(a), o.eye_height);
    const double walking = std::atan2(o.radius_y * std::cos(a), -o.radius_x * std::sin(a));
    // Positive swing turns left, towards the centre of a counter-clockwise loop.
    const double heading = walking + o.swing_deg * deg * std::sin(6 * M_PI * i / o.num_views + p[1]);
    const double pitch = (o.pitch_deg + o.wobble_deg * std::sin(5 * M_PI * i / o.num_views + p[2])) * deg;
    const Eigen::Vector3d forward(std::cos(pitch) * std::cos(heading), std::cos(pitch) * std::sin(heading),
                                  std::sin(pitch));
    const Rigid3d level = LookAt(eye, eye + forward, Eigen::Vector3d::UnitZ());
    const double roll = o.wobble_deg * deg * std::sin(7 * M_PI * i / o.num_views + p[3]);
    const Eigen::Quaterniond rotation = Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()) * level.rotation;
    out.push_back({camera, Rigid3d(rotation, -(rotation * eye))});
  }
  return out;
}

}  // namespace nerfreg
