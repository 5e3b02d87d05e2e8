#include "nerfreg/registration/point_registration.h"

#include <Eigen/Eigenvalues>
#include <stdexcept>

#include "nerfreg/util/logging.h"

namespace nerfreg {

ClassicalRegistrationOptions FpfhOptions(double voxel) {
  ClassicalRegistrationOptions o;
  o.voxel_size = voxel;
  o.normal_radius = 2 * voxel;
  o.feature_radius = 5 * voxel;
  return o;
}

RegistrationResult RegisterPoints(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                  RegistrationMethod method, const BlockRegistrationOptions& o) {
  ClassicalRegistrationOptions c = FpfhOptions(o.voxel);
  c.method = method == RegistrationMethod::kFgr ? "fgr" : "ransac";
  c.icp = o.refine != RegistrationRefinement::kNone;
  c.seed = o.seed;
  c.max_points = o.max_points;
  c.with_scaling = o.scale == ScaleMode::kFree;
  ClassicalRegistrationResult r;
  if (source.cols() >= 3 && target.cols() >= 3) r = RegisterPointClouds(source, target, c);
  RegistrationResult out;
  out.method = c.method + (c.icp ? "+icp" : "");
  out.target_from_source = r.TargetFromSource();
  out.method_score = r.fitness;
  out.seconds = r.seconds;
  out.source_points = static_cast<int>(source.cols());
  out.target_points = static_cast<int>(target.cols());
  out.cloud = RegistrationCloud::kOccupied;
  out.details = {{"inlier_rmse", r.inlier_rmse},     {"register_seconds", r.seconds},
                 {"source_points", source.cols()},   {"target_points", target.cols()},
                 {"feature_voxel", r.feature_voxel}, {"feature_points", {r.source_points, r.target_points}}};
  return out;
}

Eigen::Matrix3d PrincipalAxes(const Eigen::Matrix3Xd& points, Eigen::Vector3d* centroid) {
  *centroid = points.rowwise().mean();
  const Eigen::Matrix3Xd centred = points.colwise() - *centroid;  // [3, N]
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(centred * centred.transpose()).eigenvectors();
}

// ICP on the D = 32 grids drifts even from the true pose, most at low overlap; on the finer
// occupied points it lands closer (docs/notes/2026-11-24-block-icp-and-agreement.md). It only
// polishes a pose already in its basin. The recorded fitness is no overlap check (blocks of
// different objects reach high fitness too).
Sim3d RefineOnBlockPoints(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Sim3d& start, double voxel,
                          Json* json, bool with_scaling) {
  if (src.cols() < 3 || tgt.cols() < 3) {
    LOG_WARN("block ICP: fewer than 3 occupied points in a block; pose left as it was");
    *json = {{"fitness", 0.0}, {"seconds", 0.0}, {"source_points", src.cols()}, {"target_points", tgt.cols()}};
    return start;
  }
  // A Sim(3) start: ICP aligns the scaled source (and with scaling, scales it further).
  ClassicalRegistrationOptions c = FpfhOptions(voxel);
  c.with_scaling = with_scaling;
  const ClassicalRegistrationResult r = RefineWithIcp(start.scale * src, tgt, start.ToRigid(), c);
  *json = {{"fitness", r.fitness},
           {"inlier_rmse", r.inlier_rmse},
           {"seconds", r.seconds},
           {"before", MatrixToJson(start.ToMatrix())}};
  return Sim3d(start.scale * r.scale, r.target_from_source.rotation, r.target_from_source.translation);
}

std::vector<Sim3d> RefineOnBlockPoints(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                                       const std::vector<Sim3d>& starts, double voxel) {
  if (starts.empty()) return {};
  if (src.cols() < 3 || tgt.cols() < 3) {
    LOG_WARN("block ICP: fewer than 3 occupied points in a block; poses left as they were");
    return starts;
  }
  const double scale = starts.front().scale;
  std::vector<Rigid3d> rigid;
  for (const Sim3d& s : starts) {
    if (s.scale != scale) throw std::invalid_argument("RefineOnBlockPoints: the starts' scales differ");
    rigid.push_back(s.ToRigid());
  }
  const std::vector<ClassicalRegistrationResult> r = RefineWithIcp(scale * src, tgt, rigid, FpfhOptions(voxel));
  std::vector<Sim3d> out;
  for (const ClassicalRegistrationResult& k : r)
    out.emplace_back(scale, k.target_from_source.rotation, k.target_from_source.translation);
  return out;
}

}  // namespace nerfreg
