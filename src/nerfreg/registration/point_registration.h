#pragma once
// The classical method on point sets (Open3D FPFH + RANSAC / FGR, point-to-plane ICP;
// reg_baselines/baselines.h) as the chain runs it: its parameters from one voxel (FpfhOptions, the
// only place the rule is written), the coarse stage on the inputs' occupied points, and ICP on
// those points after a grid method ("block ICP").
#include <Eigen/Core>
#include <vector>

#include "nerfreg/reg_baselines/baselines.h"
#include "nerfreg/registration/registration_options.h"
#include "nerfreg/registration/registration_result.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// The spec's FPFH parameters at downsampling voxel `voxel` (scene units): normals within 2 voxels,
// FPFH within 5, ICP correspondences within 2 (ClassicalRegistrationOptions' default).
ClassicalRegistrationOptions FpfhOptions(double voxel);

// FPFH + RANSAC (kRansac) or FGR (kFgr) on occupied points `source`, `target` ([3, N], each input's
// frame) at options.voxel, capped at options.max_points, then point-to-plane ICP unless
// options.refine is kNone; with options.scale kFree, RANSAC and ICP estimate a scale too
// (ClassicalRegistrationOptions::with_scaling). method "ransac+icp", ...; method_score the fitness; details the record
// T.json keeps (inlier_rmse, register_seconds, source_points, target_points, feature_voxel,
// feature_points). Fewer than 3 points in a cloud: identity with method_score 0.
RegistrationResult RegisterPoints(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                  RegistrationMethod method, const BlockRegistrationOptions& options);

// The principal axes of `points` ([3, N]): columns by increasing spread; `centroid` gets their
// mean. The half-turn check of grid ICP and the turn check turn poses about them.
Eigen::Matrix3d PrincipalAxes(const Eigen::Matrix3Xd& points, Eigen::Vector3d* centroid);

// ICP on the blocks' occupied points (`src`, `tgt`: [3, N]) from `start`, after ICP on the grids:
// point-to-plane at `voxel`, correspondences within 2 voxels; the start's scale is kept unless
// `with_scaling` (then point-to-point ICP with scaling first). `json` records it (fitness,
// inlier_rmse, seconds, before).
Sim3d RefineOnBlockPoints(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Sim3d& start, double voxel,
                          Json* json, bool with_scaling = false);
// The same, rigid, from several starts that share a scale (the turn check's; std::invalid_argument
// otherwise), the clouds prepared once and the starts run in parallel (RefineWithIcp): one pose
// per start, as RefineOnBlockPoints(src, tgt, start, voxel, ..., false) gives it.
std::vector<Sim3d> RefineOnBlockPoints(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                                       const std::vector<Sim3d>& starts, double voxel);

}  // namespace nerfreg
