#include "nerfreg/reg/register_grids.h"

#include <algorithm>

#include "nerfreg/reg/baselines.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

void GridRegistrationOptions::Check() const {
  if (method != "dreg" && method != "ransac" && method != "fgr") ThrowInputError("--method", "", "dreg, ransac or fgr");
  if (!(voxel > 0)) ThrowInputError("--voxel", "", "> 0");
  if (!(inlier_radius > 0)) ThrowInputError("--inlier-radius", "", "> 0");
  DregSolveOptions solve;
  solve.solver = dreg_solver;
  solve.passes = dreg_passes;
  solve.inlier_radius = inlier_radius;
  solve.Check();
}

GridRegistrationResult RegisterGrids(const RegGrid& source, const RegGrid& target, const GridRegistrationOptions& o,
                                     DregNet* net) {
  o.Check();
  Timer timer;
  GridRegistrationResult r;
  r.method = o.Name();
  const Eigen::Matrix3Xd src = PointsToEigen(source.MaskedXyz()), tgt = PointsToEigen(target.MaskedXyz());
  r.source_points = static_cast<int>(src.cols());
  r.target_points = static_cast<int>(tgt.cols());
  if (src.cols() < 8 || tgt.cols() < 8) {
    r.seconds = timer.Seconds();
    return r;  // nothing to register: identity, confidence 0
  }
  // The classical pipeline's voxel is at least the grid's cell: finer, the normals (2 voxels) and
  // FPFH (5 voxels) find no neighbours among one point per cell (on the spider's real blocks at
  // D = 32: RANSAC + ICP 171 deg off at 0.05, 1.9 deg at 0.12).
  const double voxel = std::max(o.voxel, 1.1 * std::max(source.CellSize(), target.CellSize()));
  ClassicalRegistrationOptions c;
  c.voxel_size = voxel;
  c.normal_radius = 2 * voxel;
  c.feature_radius = 5 * voxel;
  c.seed = o.seed;
  Rigid3d estimate;
  if (o.method == "dreg") {
    if (!net) throw std::logic_error("RegisterGrids: method dreg needs the network");
    DregSolveOptions solve;
    solve.solver = o.dreg_solver;
    solve.passes = o.dreg_passes;
    solve.inlier_radius = o.inlier_radius;
    solve.seed = o.seed;
    const DregRegistration d = Register(*net, source, target, solve);
    r.scale = d.scale;
    r.confidence = d.confidence;
    const Eigen::Matrix3d sr = d.target_from_source.topLeftCorner<3, 3>() / d.scale;
    estimate = Rigid3d(sr, d.target_from_source.topRightCorner<3, 1>());
    if (o.icp) {
      // ICP refines a rigid pose: with a scale estimate, refine in the scaled source frame.
      Eigen::Matrix3Xd scaled = src * d.scale;
      estimate = RefineWithIcp(scaled, tgt, estimate, c).target_from_source;
      r.target_from_source = estimate.ToMatrix();
      r.target_from_source.topLeftCorner<3, 3>() *= d.scale;
    } else {
      r.target_from_source = d.target_from_source;
    }
  } else {
    c.method = o.method;
    c.icp = o.icp;
    const ClassicalRegistrationResult cr = RegisterPointClouds(src, tgt, c);
    r.target_from_source = cr.target_from_source.ToMatrix();
    r.confidence = cr.fitness;
  }
  r.seconds = timer.Seconds();
  return r;
}

}  // namespace nerfreg
