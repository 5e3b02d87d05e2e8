#include "nerfreg/reg_baselines/baselines.h"

#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/FastGlobalRegistration.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/utility/Logging.h>
#include <open3d/utility/Random.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "nerfreg/util/omp_threads.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace reg = open3d::pipelines::registration;

void ClassicalRegistrationOptions::Check() const {
  if ((method != "ransac" && method != "fgr") || !(voxel_size > 0) || !(normal_radius > 0) || !(feature_radius > 0) ||
      max_correspondence_distance < 0 || ransac_iterations < 1 || !(ransac_confidence > 0 && ransac_confidence <= 1) ||
      icp_distance < 0 || max_points < 0 || !(max_scale_change >= 1)) {
    throw std::invalid_argument("ClassicalRegistrationOptions: out of range (method ransac or fgr)");
  }
}

namespace {

open3d::geometry::PointCloud ToCloud(const Eigen::Matrix3Xd& pts) {
  open3d::geometry::PointCloud cloud;
  for (Eigen::Index i = 0; i < pts.cols(); ++i) cloud.points_.push_back(pts.col(i));
  return cloud;
}

// Downsampled at `voxel`, normals within normal_radius scaled as the voxel is.
std::shared_ptr<open3d::geometry::PointCloud> Prepare(const open3d::geometry::PointCloud& cloud,
                                                      const ClassicalRegistrationOptions& o, double voxel) {
  auto down = cloud.VoxelDownSample(voxel);
  down->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(o.normal_radius * voxel / o.voxel_size, 30));
  return down;
}

std::shared_ptr<open3d::geometry::PointCloud> Prepare(const Eigen::Matrix3Xd& pts,
                                                      const ClassicalRegistrationOptions& o) {
  return Prepare(ToCloud(pts), o, o.voxel_size);
}

ClassicalRegistrationResult ToResult(const reg::RegistrationResult& r, size_t source_points, size_t target_points,
                                     double seconds) {
  ClassicalRegistrationResult out;
  // Open3D may return a numerically slightly non-orthonormal rotation: project it.
  // A similarity's scale is the cube root of det(sR) (1 for a rigid result).
  const Eigen::Matrix3d sr = r.transformation_.topLeftCorner<3, 3>();
  const double det = sr.determinant();
  out.scale = det > 0 ? std::cbrt(det) : 1.0;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sr / out.scale, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d rot = svd.matrixU() * svd.matrixV().transpose();
  if (rot.determinant() < 0) rot = -rot;
  out.target_from_source = Rigid3d(rot, r.transformation_.topRightCorner<3, 1>());
  out.fitness = r.fitness_;
  out.inlier_rmse = r.inlier_rmse_;
  out.seconds = seconds;
  out.source_points = static_cast<int>(source_points);
  out.target_points = static_cast<int>(target_points);
  return out;
}

// Whether the similarity m's scale is within a factor max_change of 1.
bool WithinScaleChange(const Eigen::Matrix4d& m, double max_change) {
  const double scale = std::cbrt(m.topLeftCorner<3, 3>().determinant());
  return scale <= max_change && scale >= 1 / max_change;
}

// Point-to-plane ICP from `start`; with_scaling: point-to-point ICP with scaling first (the
// point-to-plane pass composes rigid updates with its start, so it keeps that scale).
reg::RegistrationResult Icp(const open3d::geometry::PointCloud& src, const open3d::geometry::PointCloud& tgt,
                            double distance, const Eigen::Matrix4d& start, const ClassicalRegistrationOptions& o) {
  Eigen::Matrix4d init = start;
  if (o.with_scaling) {
    const Eigen::Matrix4d scaled =
        reg::RegistrationICP(src, tgt, distance, start, reg::TransformationEstimationPointToPoint(true),
                             reg::ICPConvergenceCriteria(1e-7, 1e-7, 100))
            .transformation_;
    const double start_scale = std::cbrt(start.topLeftCorner<3, 3>().determinant());
    if (WithinScaleChange(scaled / start_scale, o.max_scale_change)) init = scaled;
  }
  return reg::RegistrationICP(src, tgt, distance, init, reg::TransformationEstimationPointToPlane(),
                              reg::ICPConvergenceCriteria(1e-7, 1e-7, 60));
}

}  // namespace

ClassicalRegistrationResult RegisterPointClouds(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                                const ClassicalRegistrationOptions& o) {
  o.Check();
  if (source.cols() < 3 || target.cols() < 3)
    throw std::invalid_argument("RegisterPointClouds: a cloud has fewer than 3 points");
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  Timer timer;
  const open3d::geometry::PointCloud src_full = ToCloud(source), tgt_full = ToCloud(target);
  // The same voxel for both clouds (their features must be comparable), coarsened until both fit
  // max_points.
  double voxel = o.voxel_size;
  auto too_many = [&](double v) {
    return o.max_points > 0 &&
           std::max(src_full.VoxelDownSample(v)->points_.size(), tgt_full.VoxelDownSample(v)->points_.size()) >
               static_cast<size_t>(o.max_points);
  };
  while (too_many(voxel)) voxel *= 1.25;
  const double k = voxel / o.voxel_size;
  const auto src = Prepare(src_full, o, voxel), tgt = Prepare(tgt_full, o, voxel);
  const auto f_src =
      reg::ComputeFPFHFeature(*src, open3d::geometry::KDTreeSearchParamHybrid(o.feature_radius * k, 100));
  const auto f_tgt =
      reg::ComputeFPFHFeature(*tgt, open3d::geometry::KDTreeSearchParamHybrid(o.feature_radius * k, 100));
  reg::RegistrationResult r;
  // One OpenMP thread: Open3D's RANSAC draws its samples from one generator shared by every thread
  // (under a mutex), and its ICP gathers the correspondences and adds up the normal equations in
  // the order the threads finish: with several threads one input and seed give different poses
  // from run to run (bits in ICP, the hypothesis in RANSAC, which the candidate choice can turn
  // into another answer). Normals and FPFH features are written per point and stay parallel.
  const ScopedOmpThreads one_thread(1);
  open3d::utility::random::Seed(static_cast<int>(o.seed));
  if (o.method == "ransac") {
    const double dist = o.max_correspondence_distance > 0 ? o.max_correspondence_distance * k : 1.5 * voxel;
    reg::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
    reg::CorrespondenceCheckerBasedOnDistance distance(dist);
    auto ransac = [&](bool with_scaling) {
      return reg::RegistrationRANSACBasedOnFeatureMatching(
          *src, *tgt, *f_src, *f_tgt, true, dist, reg::TransformationEstimationPointToPoint(with_scaling), 3,
          {edge, distance}, reg::RANSACConvergenceCriteria(o.ransac_iterations, o.ransac_confidence));
    };
    r = ransac(o.with_scaling);
    if (o.with_scaling && !WithinScaleChange(r.transformation_, o.max_scale_change)) r = ransac(false);
  } else {
    reg::FastGlobalRegistrationOption fgr;
    fgr.maximum_correspondence_distance_ = o.max_correspondence_distance > 0 ? o.max_correspondence_distance : 0.5;
    r = reg::FastGlobalRegistrationBasedOnFeatureMatching(*src, *tgt, *f_src, *f_tgt, fgr);
  }
  if (o.icp) {
    const double d = o.icp_distance > 0 ? o.icp_distance : 2 * o.voxel_size;
    const auto src_icp = voxel == o.voxel_size ? src : Prepare(src_full, o, o.voxel_size);
    const auto tgt_icp = voxel == o.voxel_size ? tgt : Prepare(tgt_full, o, o.voxel_size);
    r = Icp(*src_icp, *tgt_icp, d, r.transformation_, o);
  }
  ClassicalRegistrationResult out = ToResult(r, src->points_.size(), tgt->points_.size(), timer.Seconds());
  out.feature_voxel = voxel;
  return out;
}

ClassicalRegistrationResult RefineWithIcp(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                          const Rigid3d& initial, const ClassicalRegistrationOptions& o) {
  return RefineWithIcp(source, target, std::vector<Rigid3d>{initial}, o).front();
}

std::vector<ClassicalRegistrationResult> RefineWithIcp(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                                       const std::vector<Rigid3d>& starts,
                                                       const ClassicalRegistrationOptions& o) {
  o.Check();
  if (source.cols() < 3 || target.cols() < 3)
    throw std::invalid_argument("RefineWithIcp: a cloud has fewer than 3 points");
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  Timer prepare;
  const auto src = Prepare(source, o), tgt = Prepare(target, o);  // once for every start
  const double prepare_seconds = prepare.Seconds();
  const double d = o.icp_distance > 0 ? o.icp_distance : 2 * o.voxel_size;
  std::vector<ClassicalRegistrationResult> out(starts.size());
  // The starts spread over the threads, each start's ICP on one (repeatable ICP, see above): the
  // same results at any thread count.
  const int n = static_cast<int>(starts.size());
  const int threads = std::max(1, std::min(omp_get_max_threads(), n));
#pragma omp parallel for num_threads(threads) schedule(dynamic)
  for (int k = 0; k < n; ++k) {
    omp_set_num_threads(1);  // Open3D's own parallel loops inside, on this thread alone
    Timer one;
    const auto r = Icp(*src, *tgt, d, starts[k].ToMatrix(), o);
    out[k] = ToResult(r, src->points_.size(), tgt->points_.size(), one.Seconds() + (k == 0 ? prepare_seconds : 0));
  }
  return out;
}

}  // namespace nerfreg
