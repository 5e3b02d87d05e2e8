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
  // Estimate a scale too (Umeyama): RANSAC's hypotheses are similarities, and ICP runs
  // point-to-point with scaling (Open3D's TransformationEstimationPointToPoint(true)) before the
  // point-to-plane pass, which keeps the scale it starts from. For inputs whose units differ.
  bool with_scaling = false;
  // with_scaling: a scale further than this factor from 1 (RANSAC) or from ICP's start is dropped
  // (RANSAC runs again rigid; ICP keeps its rigid pass): the clouds are meant to be of about one
  // size (registration/scale_normalization.h), and on clouds that do not match, point-to-point
  // ICP with scaling shrinks the source towards a point.
  double max_scale_change = 1.5;
  void Check() const;  // throws std::invalid_argument
};

struct ClassicalRegistrationResult {
  // x_target = scale * target_from_source * x_source; scale is 1 unless options.with_scaling.
  Rigid3d target_from_source;
  double scale = 1.0;
  double fitness = 0;  // fraction of source points with a target point within the inlier distance
  double inlier_rmse = 0;
  double seconds = 0;
  int source_points = 0, target_points = 0;  // after downsampling (for the features)
  double feature_voxel = 0;                  // the voxel the features were computed at (voxel_size unless capped)
  Sim3d TargetFromSource() const { return Sim3d(scale, target_from_source.rotation, target_from_source.translation); }
};

// source, target: [3, N] points (block frames). Throws std::invalid_argument on empty clouds.
ClassicalRegistrationResult RegisterPointClouds(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                                const ClassicalRegistrationOptions& options);

// Point-to-plane ICP alone from an initial estimate (the refinement of a learned registration),
// on the same downsampled clouds and normals as RegisterPointClouds. Uses voxel_size,
// normal_radius and icp_distance of `options` (and with_scaling: the result's scale is relative to
// the source as given).
ClassicalRegistrationResult RefineWithIcp(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                          const Rigid3d& initial_target_from_source,
                                          const ClassicalRegistrationOptions& options);
// The same from several starts, the clouds and normals prepared once: one result per start (its
// seconds: that start's ICP, the first's with the preparation). The starts run in parallel over
// OpenMP's threads, each on one thread: the results do not depend on the thread count.
std::vector<ClassicalRegistrationResult> RefineWithIcp(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                                       const std::vector<Rigid3d>& starts,
                                                       const ClassicalRegistrationOptions& options);

}  // namespace nerfreg
