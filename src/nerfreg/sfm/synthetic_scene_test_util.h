#pragma once
// Test-only: a synthetic scene with exact ground truth for the sfm tests. Random cameras on a
// spherical cap looking at random points near the origin; per image, the projections of the
// points it sees (with pixel noise) are its keypoints; per pair, the common points are the inlier
// matches and the true relative pose (with optional noise and outliers) is the edge.
#include <Eigen/Core>
#include <random>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {

struct SyntheticSceneOptions {
  int num_cameras = 10;
  int num_points = 400;
  double keypoint_noise_px = 0.5;
  double rotation_noise_deg = 0.0;      // on every edge's relative rotation
  double direction_noise_deg = 0.0;     // on every edge's translation direction
  double outlier_edge_fraction = 0.0;   // edges whose relative pose is replaced by a random one
  double outlier_match_fraction = 0.0;  // extra wrong matches per edge, as a fraction of its inliers
  unsigned seed = 1;
  // Every camera looking along +y (one rotation), centres within 12 deg of the -y axis: the camera
  // only translates, which leaves the focal length free.
  bool pure_translation = false;
};

struct SyntheticScene {
  std::vector<Camera> cameras;
  std::vector<Rigid3d> cam_from_world;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<int>> keypoint_point;  // per image, per keypoint: its point (-1: clutter)
  std::vector<bool> outlier_edge;                // per graph edge
  ViewGraph graph;
};

inline Eigen::Vector3d SyntheticCenter(const Rigid3d& cam_from_world) {
  return -(cam_from_world.rotation.conjugate() * cam_from_world.translation);
}

inline Rigid3d SyntheticLookAt(const Eigen::Vector3d& center, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - center).normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitZ().cross(z);
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, y, z;
  const Eigen::Matrix3d r = world_from_cam.transpose();
  return Rigid3d(r, -(r * center));
}

inline Eigen::Quaterniond SmallRotation(std::mt19937& rng, double sigma_deg) {
  std::normal_distribution<double> g(0.0, sigma_deg * M_PI / 180);
  const Eigen::Vector3d w(g(rng), g(rng), g(rng));
  if (w.norm() == 0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()));
}

inline SyntheticScene MakeSyntheticScene(const SyntheticSceneOptions& o) {
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, o.keypoint_noise_px);
  SyntheticScene s;
  for (int k = 0; k < o.num_points; ++k) {
    s.points.push_back(Eigen::Vector3d(u(rng) * 3 - 1.5, u(rng) * 3 - 1.5, u(rng) * 2 - 1));
  }
  const Camera cam = Camera::Pinhole(320, 240, 280, 280, 160, 120);
  for (int c = 0; c < o.num_cameras; ++c) {
    // Centres on a cap of radius 6 within 35 degrees of the -y axis, looking near the origin.
    const double az = u(rng) * 2 * M_PI, el = u(rng) * (o.pure_translation ? 12 : 35) * M_PI / 180;
    const Eigen::Vector3d center =
        6.0 * Eigen::Vector3d(std::sin(el) * std::cos(az), -std::cos(el), std::sin(el) * std::sin(az));
    const Eigen::Vector3d target(u(rng) * 0.6 - 0.3, u(rng) * 0.6 - 0.3, u(rng) * 0.6 - 0.3);
    s.cameras.push_back(cam);
    s.cam_from_world.push_back(
        SyntheticLookAt(center, o.pure_translation ? Eigen::Vector3d(center + Eigen::Vector3d::UnitY()) : target));
  }
  const int n = o.num_cameras;
  s.graph.names.resize(n);
  s.graph.keypoints.resize(n);
  s.keypoint_point.resize(n);
  std::vector<std::vector<int>> keypoint_of(n, std::vector<int>(o.num_points, -1));
  for (int c = 0; c < n; ++c) {
    s.graph.names[c] = "img_" + std::to_string(c) + ".png";
    for (int p = 0; p < o.num_points; ++p) {
      const Eigen::Vector3d x = s.cam_from_world[c] * s.points[p];
      if (x.z() <= 0) continue;
      const Eigen::Vector2d uv = cam.ImgFromCam(x) + Eigen::Vector2d(noise(rng), noise(rng));
      if (uv.x() < 0 || uv.y() < 0 || uv.x() >= cam.width || uv.y() >= cam.height) continue;
      keypoint_of[c][p] = static_cast<int>(s.graph.keypoints[c].size());
      s.graph.keypoints[c].push_back(uv);
      s.keypoint_point[c].push_back(p);
    }
    for (int k = 0; k < 50; ++k) {  // clutter: keypoints of nothing
      s.graph.keypoints[c].push_back(Eigen::Vector2d(u(rng) * cam.width, u(rng) * cam.height));
      s.keypoint_point[c].push_back(-1);
    }
  }
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      ViewGraphEdge e;
      e.i = i;
      e.j = j;
      for (int p = 0; p < o.num_points; ++p)
        if (keypoint_of[i][p] >= 0 && keypoint_of[j][p] >= 0)
          e.inlier_matches.push_back({keypoint_of[i][p], keypoint_of[j][p]});
      if (e.inlier_matches.size() < 30) continue;
      const int num_wrong = static_cast<int>(o.outlier_match_fraction * e.inlier_matches.size());
      for (int w = 0; w < num_wrong; ++w) {
        e.inlier_matches.push_back({static_cast<int>(u(rng) * s.graph.keypoints[i].size()),
                                    static_cast<int>(u(rng) * s.graph.keypoints[j].size())});
      }
      e.num_matches = e.num_inliers = static_cast<int>(e.inlier_matches.size());
      const Rigid3d j_from_i = s.cam_from_world[j] * s.cam_from_world[i].Inverse();
      const bool outlier = u(rng) < o.outlier_edge_fraction;
      if (outlier) {
        e.j_from_i = Rigid3d(RandomRotation(u(rng), u(rng), u(rng)),
                             Eigen::Vector3d(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5).normalized());
      } else {
        const Eigen::Vector3d t = SmallRotation(rng, o.direction_noise_deg) * j_from_i.translation.normalized();
        e.j_from_i = Rigid3d(SmallRotation(rng, o.rotation_noise_deg) * j_from_i.rotation, t);
      }
      s.outlier_edge.push_back(outlier);
      s.graph.edges.push_back(e);
    }
  }
  return s;
}

// The scene's true orientations (cam_from_world rotations).
inline std::vector<Eigen::Quaterniond> TrueRotations(const SyntheticScene& s) {
  std::vector<Eigen::Quaterniond> out;
  for (const auto& p : s.cam_from_world) out.push_back(p.rotation);
  return out;
}

}  // namespace nerfreg
