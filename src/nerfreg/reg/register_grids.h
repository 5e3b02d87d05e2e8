#pragma once
// One registration of two extracted grids by any method, with one result type, so `reg register`,
// `reg eval --pairs` and the benchmarks compare methods on exactly the same input:
//  - "dreg": the DReg-NeRF network (reg/dreg_model.h) on the grids;
//  - "ransac" / "fgr": Open3D FPFH + RANSAC / FGR (reg/baselines.h) on the grids' masked points,
//    with the spec's parameters scaled by `voxel`;
// each optionally refined by point-to-plane ICP on the masked (surface) points.
#include <Eigen/Core>
#include <string>

#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/reg_grid.h"

namespace nerfreg {

struct GridRegistrationOptions {
  std::string method = "dreg";  // "dreg", "ransac" or "fgr"
  bool icp = true;              // refine with point-to-plane ICP on the masked points
  double voxel = 0.05;          // classical downsampling voxel (normals 2x, FPFH 5x, ICP distance 2x);
                                // at least 1.1 x the grids' cell is used
  double inlier_radius = 0.1;   // dreg: the radius of its confidence and of its RANSAC (DregSolveOptions)
  std::string dreg_solver = "procrustes";  // dreg: "procrustes" (the paper's) or "ransac" (DregSolveOptions)
  int dreg_passes = 1;                     // dreg: network passes (DregSolveOptions::passes)
  unsigned seed = 0;
  void Check() const;           // throws InputError naming the option
  // "dreg", "dreg+icp", "ransac+icp", ...; dreg's RANSAC solve is "dreg/ransac".
  std::string Name() const {
    return method + (method == "dreg" && dreg_solver == "ransac" ? "/ransac" : "") +
           (method == "dreg" && dreg_passes > 1 ? "/" + std::to_string(dreg_passes) + "passes" : "") + (icp ? "+icp" : "");
  }
};

struct GridRegistrationResult {
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double scale = 1;
  // dreg: the network's confidence; classical: the fitness (fraction of inliers). In [0, 1];
  // low means the answer should not be trusted (no overlap, empty grids).
  double confidence = 0;
  double seconds = 0;           // registration only (grids already extracted)
  int source_points = 0, target_points = 0;
  std::string method;
};

// `net` is needed for method dreg (and ignored otherwise). Empty or tiny masks give identity with
// confidence 0 rather than an exception: the caller warns.
GridRegistrationResult RegisterGrids(const RegGrid& source, const RegGrid& target, const GridRegistrationOptions& options,
                                     DregNet* net);

}  // namespace nerfreg
