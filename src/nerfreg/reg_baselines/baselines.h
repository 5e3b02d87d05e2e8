#pragma once
// Classical point-cloud registration through Open3D, the baselines DReg-NeRF is measured against
// (spec dreg-nerf.md 6): voxel downsample -> normals -> FPFH -> RANSAC or FGR, then
// optional point-to-plane ICP. Open3D stays behind this header: clouds are Eigen matrices.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct ClassicalRegistrationOptions {
  std::string method = "ransac";             // "ransac" (FPFH + RANSAC) or "fgr" (FPFH + fast global registration)
  double voxel_size = 0.05;                  // downsampling cell (the spec's FGR parameters)
  double normal_radius = 0.1;                // normals: radius, max 30 neighbours
  double feature_radius = 0.25;              // FPFH: radius, max 100 neighbours
  double max_correspondence_distance = 0.0;  // 0: 1.5 x voxel for RANSAC, 0.5 for FGR (spec)
  int ransac_iterations = 100000;
  double ransac_confidence = 0.999;
  bool icp = true;            // point-to-plane ICP refinement
  double icp_distance = 0.0;  // 0: 2 x voxel
  // FPFH + RANSAC / FGR cost grows with the points: when a downsampled cloud has more than this,
  // the features and the global search use a coarser voxel (x1.25 steps; the radii and the
  // RANSAC distance scale with it) and ICP still runs at voxel_size. 0: no cap.
  int max_points = 0;
  unsigned seed = 0;
  void Check() const;  // throws std::invalid_argument
};

struct ClassicalRegistrationResult {
  Rigid3d target_from_source;
  double fitness = 0;  // fraction of source points with a target point within the inlier distance
  double inlier_rmse = 0;
  double seconds = 0;
  int source_points = 0, target_points = 0;  // after downsampling (for the features)
  double feature_voxel = 0;                  // the voxel the features were computed at (voxel_size unless capped)
};

// source, target: [3, N] points (block frames). Throws std::invalid_argument on empty clouds.
ClassicalRegistrationResult RegisterPointClouds(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                                const ClassicalRegistrationOptions& options);

// Point-to-plane ICP alone from an initial estimate (the refinement of a learned registration),
// on the same downsampled clouds and normals as RegisterPointClouds. Uses voxel_size,
// normal_radius and icp_distance of `options`.
ClassicalRegistrationResult RefineWithIcp(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                          const Rigid3d& initial_target_from_source,
                                          const ClassicalRegistrationOptions& options);
// The same from several starts, the clouds and normals prepared once: one result per start (its
// seconds: that start's ICP, the first's with the preparation).
std::vector<ClassicalRegistrationResult> RefineWithIcp(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                                       const std::vector<Rigid3d>& starts,
                                                       const ClassicalRegistrationOptions& options);

}  // namespace nerfreg
