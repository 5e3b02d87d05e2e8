#include "nerfreg/sfm/relative_pose_averaging.h"

#include "nerfreg/geometry/rigid3.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace nerfreg {

void RelativePoseAveragingOptions::Check() const {
  rotation.Check();
  translation.Check();
}

RelativePoseAveragingResult GlobalPosesFromRelativePoses(int num_images, const std::vector<RelativePose>& edges,
                                                         const RelativePoseAveragingOptions& options) {
  options.Check();
  if (num_images < 0) throw std::invalid_argument("GlobalPosesFromRelativePoses: negative image count");
  // The averagings read a view graph: one edge per relative pose, the weight as an inlier count
  // (they weigh edges by sqrt(count / median count), so only ratios matter).
  ViewGraph graph;
  for (int k = 0; k < num_images; ++k) graph.names.push_back(std::to_string(k));
  graph.keypoints.resize(num_images);
  std::vector<bool> has_direction;
  for (const RelativePose& r : edges) {
    if (r.i < 0 || r.j < 0 || r.i >= num_images || r.j >= num_images || r.i == r.j || !(r.weight > 0)) {
      throw std::invalid_argument("GlobalPosesFromRelativePoses: bad edge " + std::to_string(r.i) + " -> " +
                                  std::to_string(r.j));
    }
    ViewGraphEdge e;
    e.i = r.i;
    e.j = r.j;
    e.num_inliers = std::max(1, static_cast<int>(std::lround(100 * r.weight)));
    e.num_matches = e.num_inliers;
    e.j_from_i = r.j_from_i;
    e.j_from_i.rotation.normalize();
    const double length = r.j_from_i.translation.norm();
    has_direction.push_back(length > 1e-12 && std::isfinite(length));
    e.j_from_i.translation =
        has_direction.back() ? Eigen::Vector3d(r.j_from_i.translation / length) : Eigen::Vector3d::Zero();
    graph.edges.push_back(std::move(e));
  }

  RelativePoseAveragingResult result;
  result.cam_from_world.assign(num_images, Rigid3d());
  result.posed.assign(num_images, false);
  result.edge_rotation_error_deg.assign(edges.size(), 180.0);
  result.edge_direction_error_deg.assign(edges.size(), 180.0);
  result.edge_inlier.assign(edges.size(), false);
  if (num_images == 0) return result;

  const RotationAveragingResult rotations = AverageRotations(graph, options.rotation);
  std::vector<bool> usable(edges.size(), false);
  for (size_t k = 0; k < edges.size(); ++k) usable[k] = rotations.edge_inlier[k] && has_direction[k];
  const TranslationAveragingResult centers =
      AverageTranslations(graph, rotations.cam_from_world, usable, options.translation);

  // The classical frame: the first posed camera at the identity, mean distance of the others 1.
  // (Translation averaging already put the root's centre at the origin with that mean distance;
  // only the rotation gauge differs.)
  int root = -1;
  for (int k = 0; k < num_images && root < 0; ++k)
    if (centers.solved[k]) root = k;
  if (root < 0) return result;
  const Eigen::Quaterniond root_from_world = rotations.cam_from_world[root];
  const Eigen::Vector3d root_center = centers.centers[root];
  for (int k = 0; k < num_images; ++k) {
    if (!centers.solved[k]) continue;
    result.posed[k] = true;
    // new world = root camera frame: x_new = R_root (x_old - c_root).
    const Eigen::Quaterniond r = (rotations.cam_from_world[k] * root_from_world.conjugate()).normalized();
    const Eigen::Vector3d c = root_from_world * (centers.centers[k] - root_center);
    result.cam_from_world[k] = Rigid3d(r, -(r * c));
  }
  for (size_t k = 0; k < edges.size(); ++k) {
    const ViewGraphEdge& e = graph.edges[k];
    if (!result.posed[e.i] || !result.posed[e.j]) continue;
    const Rigid3d j_from_i = result.cam_from_world[e.j] * result.cam_from_world[e.i].Inverse();
    result.edge_rotation_error_deg[k] = RotationErrorDeg(j_from_i.rotation, e.j_from_i.rotation);
    if (usable[k]) {
      // Centres: c_j - c_i is parallel to -R_j^T t_ij.
      const Eigen::Vector3d ci = result.cam_from_world[e.i].Inverse().translation;
      const Eigen::Vector3d cj = result.cam_from_world[e.j].Inverse().translation;
      result.edge_direction_error_deg[k] =
          DirectionAngleDeg(cj - ci, -(result.cam_from_world[e.j].rotation.conjugate() * e.j_from_i.translation));
    }
    result.edge_inlier[k] = usable[k] && result.edge_rotation_error_deg[k] <= options.rotation.max_edge_error_deg &&
                            result.edge_direction_error_deg[k] <= options.translation.max_edge_error_deg;
  }
  return result;
}

}  // namespace nerfreg
