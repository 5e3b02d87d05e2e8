#pragma once
// The chain's first stage on grids (registration/registration_chain.h): one registration of two
// extracted grids by any method, so `reg register`, `reg eval --pairs` and the benchmarks compare
// methods on exactly the same input:
//  - kDreg: the DReg-NeRF network (reg/dreg_model.h) on the grids;
//  - kRansac / kFgr: Open3D FPFH + RANSAC / FGR (reg_baselines/baselines.h) on the grids' masked
//    points, with the spec's parameters scaled by `voxel` (FpfhOptions);
// each optionally refined by point-to-plane ICP (on the occupied or the masked points), the pose
// also checked against its half-turns about the object's axes (`flips`).
#include <Eigen/Core>
#include <string>

#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/registration/registration_options.h"
#include "nerfreg/registration/registration_result.h"

namespace nerfreg {

struct GridRegistrationOptions {
  RegistrationMethod method = RegistrationMethod::kDreg;  // kDreg, kRansac or kFgr (kAuto is no grid method)
  bool icp = true;                                        // refine with point-to-plane ICP on `icp_points`
  // The points ICP aligns: kOccupied (every voxel over the density threshold) or kMask (the
  // surface mask the network and the features see). The mask keeps the surface the block's
  // cameras saw; the occupied voxels add the thickness a trained field gives a surface and fix it
  // better on real blocks (on synthesised pairs, whose extra voxels are simulated blur, the mask
  // does; docs/notes/2026-11-23-grids-icp-half-turn.md).
  IcpPoints icp_points = IcpPoints::kOccupied;
  double voxel = 0.05;                        // classical downsampling voxel (normals 2x, FPFH 5x); at least 1.1 x
                                              // the grids' cell is used
  double icp_distance = kDefaultIcpDistance;  // ICP's correspondence distance, in those voxels
  double inlier_radius = 0.1;                 // dreg: the radius of its confidence and of its RANSAC (DregSolveOptions)
  DregSolver dreg_solver = DregSolver::kProcrustes;  // dreg: the paper's or RANSAC (DregSolveOptions)
  int dreg_passes = 1;                               // dreg: network passes (DregSolveOptions::passes)
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

// The grid options a registration's options imply for `method` (icp: unless refine is kNone).
GridRegistrationOptions GridOptionsFor(const BlockRegistrationOptions& options, RegistrationMethod method);

// ICP from `start` (a similarity: its scale is kept) on `options.icp_points` and, with
// `options.flips`, from its 9 half-turns; the refined pose whose voxels agree best
// (GridAgreement), the first unless a half-turn beats it by 0.03. `flip`: the half-turn kept or -1.
Sim3d RefineGridPose(const RegGrid& source, const RegGrid& target, const Sim3d& start,
                     const GridRegistrationOptions& options, int* flip = nullptr);

// How well the source's occupied voxels, moved by target_from_source, land on occupied target
// voxels of the same colour: the mean over source voxels of the best, among the target voxel they
// fall in and its 26 neighbours, of max(0, 1 - |rgb difference| / 0.3) (0 where none is
// occupied). In [0, 1]; compares poses of the same pair (the overlap bounds it).
double GridAgreement(const RegGrid& source, const RegGrid& target, const Sim3d& target_from_source);

// `net` is needed for method dreg (and ignored otherwise). Empty or tiny masks give identity with
// method_score 0 rather than an exception: the caller warns. The result's method is
// options.Name(), its half_turn the one kept, its cloud kGridMask.
RegistrationResult RegisterGrids(const RegGrid& source, const RegGrid& target, const GridRegistrationOptions& options,
                                 DregNet* net);

}  // namespace nerfreg
