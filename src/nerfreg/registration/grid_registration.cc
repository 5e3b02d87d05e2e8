#include "nerfreg/registration/grid_registration.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <vector>

#include "nerfreg/reg_baselines/baselines.h"
#include "nerfreg/registration/point_registration.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

void GridRegistrationOptions::Check() const {
  if (method == RegistrationMethod::kAuto) ThrowInputError("--method", "", "dreg, ransac or fgr");
  if (!(voxel > 0)) ThrowInputError("--voxel", "", "> 0");
  if (!(inlier_radius > 0)) ThrowInputError("--inlier-radius", "", "> 0");
  if (!(icp_distance > 0)) ThrowInputError("--icp-distance", "", "> 0 (ICP voxels)");
  DregSolveOptions solve;
  solve.solver = DregSolverName(dreg_solver);
  solve.passes = dreg_passes;
  solve.inlier_radius = inlier_radius;
  solve.Check();
}

GridRegistrationOptions GridOptionsFor(const BlockRegistrationOptions& o, RegistrationMethod method) {
  GridRegistrationOptions g;
  g.method = method;
  g.dreg_solver = o.dreg_solver;
  g.dreg_passes = o.dreg_passes;
  g.icp = o.refine != RegistrationRefinement::kNone;
  g.icp_points = o.icp_points;
  g.flips = o.flips;
  g.icp_distance = o.icp_distance;
  g.voxel = o.voxel;
  g.seed = o.seed;
  return g;
}

std::string GridRegistrationOptions::Name() const {
  const bool dreg = method == RegistrationMethod::kDreg;
  std::string name = RegistrationMethodName(method) + (dreg && dreg_solver == DregSolver::kRansac ? "/ransac" : "") +
                     (dreg && dreg_passes > 1 ? "/" + std::to_string(dreg_passes) + "passes" : "");
  if (!icp) return name;
  name += std::string("+icp") + (icp_points == IcpPoints::kMask ? "[mask]" : "") + (flips ? "" : "[noflips]");
  if (icp_distance != kDefaultIcpDistance) {
    char d[32];
    std::snprintf(d, sizeof d, "[d%g]", icp_distance);
    name += d;
  }
  return name;
}

double GridAgreement(const RegGrid& source, const RegGrid& target, const Sim3d& target_from_source) {
  torch::NoGradGuard no_grad;
  const torch::Tensor occupied = source.Occupied();                                              // [D, D, D]
  const torch::Tensor xyz = source.xyz.index({occupied}).to(torch::kDouble);                     // [K, 3]
  const torch::Tensor rgb = source.rgba.slice(0, 0, 3).permute({1, 2, 3, 0}).index({occupied});  // [K, 3]
  if (xyz.size(0) == 0) return 0;
  const Eigen::Matrix4d m = target_from_source.ToMatrix();
  const torch::Tensor r =
      torch::tensor({m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)}, torch::kDouble)
          .view({3, 3});
  const torch::Tensor t = torch::tensor({m(0, 3), m(1, 3), m(2, 3)}, torch::kDouble);
  const torch::Tensor lo =
      torch::tensor({target.aabb_min.x(), target.aabb_min.y(), target.aabb_min.z()}, torch::kDouble);
  const torch::Tensor cell = (xyz.matmul(r.t()) + t - lo) / target.CellSize();  // [K, 3] in target cells
  const torch::Tensor base = cell.floor().to(torch::kLong);
  const int64_t d = target.Resolution();
  const torch::Tensor tgt_rgba = target.rgba.reshape({4, -1});  // [4, D^3]
  const torch::Tensor tgt_occupied = target.Occupied().reshape({-1});
  torch::Tensor best = torch::zeros({xyz.size(0)});
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        const torch::Tensor ijk = base + torch::tensor({dx, dy, dz}, torch::kLong);
        const torch::Tensor inside = ((ijk >= 0) & (ijk < d)).all(1);
        const torch::Tensor flat = (ijk.clamp(0, d - 1) * torch::tensor({d * d, d, int64_t{1}}, torch::kLong)).sum(1);
        const torch::Tensor there = tgt_rgba.slice(0, 0, 3).index_select(1, flat).t();  // [K, 3]
        const torch::Tensor agree = (1 - (there - rgb).norm(2, 1) / 0.3).clamp_min(0) *
                                    (inside & tgt_occupied.index_select(0, flat)).to(torch::kFloat);
        best = torch::maximum(best, agree);
      }
  return best.mean().item<double>();
}

namespace {

ClassicalRegistrationOptions ClassicalOptionsFor(const RegGrid& source, const RegGrid& target,
                                                 const GridRegistrationOptions& o) {
  // The classical pipeline's voxel is at least the grid's cell: finer, the normals (2 voxels) and
  // FPFH (5 voxels) find no neighbours among one point per cell
  // (docs/notes/2026-11-22-nerf-and-classical-defaults.md).
  ClassicalRegistrationOptions c = FpfhOptions(std::max(o.voxel, 1.1 * std::max(source.CellSize(), target.CellSize())));
  c.icp_distance = o.icp_distance * c.voxel_size;
  c.seed = o.seed;
  return c;
}

Eigen::Matrix3Xd GridIcpPoints(const RegGrid& grid, const GridRegistrationOptions& o) {
  return PointsToEigen(o.icp_points == IcpPoints::kOccupied ? grid.OccupiedXyz() : grid.MaskedXyz());
}

}  // namespace

Sim3d RefineGridPose(const RegGrid& source, const RegGrid& target, const Sim3d& start, const GridRegistrationOptions& o,
                     int* flip) {
  o.Check();
  if (flip) *flip = -1;
  const ClassicalRegistrationOptions c = ClassicalOptionsFor(source, target, o);
  const Eigen::Matrix3Xd tgt_icp = GridIcpPoints(target, o);
  const double scale = start.scale;
  // ICP refines a rigid pose: with a scale, refine in the scaled source frame.
  const Eigen::Matrix3Xd scaled = GridIcpPoints(source, o) * scale;
  if (scaled.cols() < 3 || tgt_icp.cols() < 3) return start;
  const Rigid3d estimate = start.ToRigid();
  std::vector<Rigid3d> starts = {estimate};
  if (o.flips) {
    // Half-turns through the (scaled) source's centroid about its principal axes and the
    // diagonals between each two of them (start = estimate * half-turn): an object's symmetry need
    // not follow one principal axis where two spreads are alike (the milk truck's height and
    // width: its front-to-back turn was found about a diagonal).
    Eigen::Vector3d centroid;
    const Eigen::Matrix3d e = PrincipalAxes(scaled, &centroid);
    std::vector<Eigen::Vector3d> axes = {e.col(0), e.col(1), e.col(2)};
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j) {
        axes.push_back((e.col(i) + e.col(j)).normalized());
        axes.push_back((e.col(i) - e.col(j)).normalized());
      }
    for (const Eigen::Vector3d& axis : axes) {
      const Eigen::Matrix3d half = Eigen::AngleAxisd(M_PI, axis).toRotationMatrix();
      starts.push_back(estimate * Rigid3d(half, centroid - half * centroid));
    }
  }
  const std::vector<ClassicalRegistrationResult> refined = RefineWithIcp(scaled, tgt_icp, starts, c);
  auto pose = [&](size_t k) {
    return Sim3d(scale, refined[k].target_from_source.rotation, refined[k].target_from_source.translation);
  };
  Sim3d best_pose = pose(0);
  if (refined.size() > 1) {
    // The first pose is kept unless a half-turn agrees clearly better (a margin against noise
    // where an object is truly symmetric).
    const double kMargin = 0.03;
    double best = GridAgreement(source, target, best_pose) + kMargin;
    for (size_t k = 1; k < refined.size(); ++k) {
      const Sim3d m = pose(k);
      const double agreement = GridAgreement(source, target, m);
      if (agreement > best) {
        best = agreement;
        best_pose = m;
        if (flip) *flip = static_cast<int>(k) - 1;
      }
    }
  }
  return best_pose;
}

RegistrationResult RegisterGrids(const RegGrid& source, const RegGrid& target, const GridRegistrationOptions& o,
                                 DregNet* net) {
  o.Check();
  Timer timer;
  RegistrationResult r;
  r.method = o.Name();
  r.cloud = RegistrationCloud::kGridMask;
  const Eigen::Matrix3Xd src = PointsToEigen(source.MaskedXyz()), tgt = PointsToEigen(target.MaskedXyz());
  r.source_points = static_cast<int>(src.cols());
  r.target_points = static_cast<int>(tgt.cols());
  if (src.cols() < 8 || tgt.cols() < 8) {
    r.seconds = timer.Seconds();
    return r;  // nothing to register: identity, method_score 0
  }
  ClassicalRegistrationOptions c = ClassicalOptionsFor(source, target, o);
  if (o.method == RegistrationMethod::kDreg) {
    if (!net) throw std::logic_error("RegisterGrids: method dreg needs the network");
    DregSolveOptions solve;
    solve.solver = DregSolverName(o.dreg_solver);
    solve.passes = o.dreg_passes;
    solve.inlier_radius = o.inlier_radius;
    solve.seed = o.seed;
    const DregRegistration d = Register(*net, source, target, solve);
    r.target_from_source = Sim3d::FromMatrix(d.target_from_source, 1e-3);
    r.method_score = d.confidence;
  } else {
    // The global search on the mask; the refinement as dreg's (the same points and half-turns).
    c.method = RegistrationMethodName(o.method);
    c.icp = false;
    const ClassicalRegistrationResult cr = RegisterPointClouds(src, tgt, c);
    r.target_from_source = Sim3d(cr.target_from_source);
    r.method_score = cr.fitness;
  }
  if (o.icp) r.target_from_source = RefineGridPose(source, target, r.target_from_source, o, &r.half_turn);
  r.seconds = timer.Seconds();
  return r;
}

}  // namespace nerfreg
