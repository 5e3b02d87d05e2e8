#pragma once
// One registration of two extracted grids by any method, with one result type, so `reg register`,
// `reg eval --pairs` and the benchmarks compare methods on exactly the same input:
//  - "dreg": the DReg-NeRF network (reg/dreg_model.h) on the grids;
//  - "ransac" / "fgr": Open3D FPFH + RANSAC / FGR (reg_baselines/baselines.h) on the grids' masked points,
//    with the spec's parameters scaled by `voxel`;
// each optionally refined by point-to-plane ICP (on the occupied or the masked points), the pose
// also checked against its half-turns about the object's axes (`flips`).
#include <Eigen/Core>
#include <string>

#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/reg_grid.h"

namespace nerfreg {

struct GridRegistrationOptions {
  std::string method = "dreg";  // "dreg", "ransac" or "fgr"
  bool icp = true;              // refine with point-to-plane ICP on `icp_points`
  // The points ICP aligns: "occupied" (every voxel over the density threshold) or "mask" (the
  // surface mask the network and the features see). The mask keeps the surface the block's
  // cameras saw; the occupied voxels add the thickness a trained field gives a surface and fix it
  // better on real blocks (on synthesised pairs, whose extra voxels are simulated blur, the mask
  // does; docs/notes/2026-11-23-grids-icp-half-turn.md).
  std::string icp_points = "occupied";
  double voxel = 0.05;  // classical downsampling voxel (normals 2x, FPFH 5x); at least 1.1 x
                        // the grids' cell is used
  // ICP's correspondence distance, in those voxels. Shorter fixes a converged pose more tightly
  // but narrows the basin the network's pose must land in, and on the held-out real pairs the
  // narrower basin cost more registrations than the tighter fit gained
  // (docs/notes/2026-11-23-grids-icp-half-turn.md, "ICP correspondence distance").
  static constexpr double kDefaultIcpDistance = 2.0;
  double icp_distance = kDefaultIcpDistance;
  double inlier_radius = 0.1;              // dreg: the radius of its confidence and of its RANSAC (DregSolveOptions)
  std::string dreg_solver = "procrustes";  // dreg: "procrustes" (the paper's) or "ransac" (DregSolveOptions)
  int dreg_passes = 1;                     // dreg: network passes (DregSolveOptions::passes)
  // With ICP (any method): also try the pose turned by 180 deg about 9 axes through the source's
  // occupied voxels (their principal axes and the diagonals between them), refine each with ICP
  // and keep the one whose voxels agree best with the target's in place and colour
  // (GridAgreement). The network's worst failures on real blocks are such half-turns of
  // near-symmetric objects (the spider upside down, the milk truck front to back: 170-179 deg),
  // which ICP's geometry alone cannot tell apart but colour can.
  bool flips = true;
  unsigned seed = 0;
  void Check() const;  // throws InputError naming the option
  // "dreg", "dreg+icp", "ransac+icp", ...; dreg's RANSAC solve is "dreg/ransac".
  std::string Name() const;
};

struct GridRegistrationResult {
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double scale = 1;
  // dreg: the network's confidence; classical: the fitness (fraction of inliers). In [0, 1];
  // low means the answer should not be trusted (no overlap, empty grids).
  double confidence = 0;
  double seconds = 0;  // registration only (grids already extracted)
  int source_points = 0, target_points = 0;
  std::string method;
  int flip = -1;  // with ICP and flips: the half-turn kept (-1: none, 0-8: the axis)
};

// ICP from `start` (a similarity: its scale is kept) on `options.icp_points` and, with
// `options.flips`, from its 9 half-turns; the refined pose whose voxels agree best
// (GridAgreement), the first unless a half-turn beats it by 0.03. `flip`: the half-turn kept or -1.
Eigen::Matrix4d RefineGridPose(const RegGrid& source, const RegGrid& target, const Eigen::Matrix4d& start,
                               const GridRegistrationOptions& options, int* flip = nullptr);

// How well the source's occupied voxels, moved by target_from_source, land on occupied target
// voxels of the same colour: the mean over source voxels of the best, among the target voxel they
// fall in and its 26 neighbours, of max(0, 1 - |rgb difference| / 0.3) (0 where none is
// occupied). In [0, 1]; compares poses of the same pair (the overlap bounds it).
double GridAgreement(const RegGrid& source, const RegGrid& target, const Eigen::Matrix4d& target_from_source);

// `net` is needed for method dreg (and ignored otherwise). Empty or tiny masks give identity with
// confidence 0 rather than an exception: the caller warns.
GridRegistrationResult RegisterGrids(const RegGrid& source, const RegGrid& target,
                                     const GridRegistrationOptions& options, DregNet* net);

}  // namespace nerfreg
