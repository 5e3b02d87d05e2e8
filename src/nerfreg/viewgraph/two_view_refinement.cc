#include "nerfreg/viewgraph/two_view_refinement.h"

#include <ceres/jet.h>
#include <ceres/rotation.h>
#include <ceres/tiny_solver.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include <array>
#include <cmath>
#include <Eigen/Geometry>

namespace nerfreg {
namespace {

// The Sampson distance of (xi, xj) to e = [t]x R, for doubles and Ceres' jets alike.
template <typename T>
T Sampson(const Eigen::Matrix<T, 3, 3>& e, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj) {
  const Eigen::Matrix<T, 3, 1> a = xi.homogeneous().cast<T>(), b = xj.homogeneous().cast<T>();
  const Eigen::Matrix<T, 3, 1> ea = e * a, eb = e.transpose() * b;
  const T den = ea.template head<2>().squaredNorm() + eb.template head<2>().squaredNorm();
  return den > T(0) ? b.dot(ea) / sqrt(den) : T(0);
}

template <typename T>
Eigen::Matrix<T, 3, 3> SkewOf(const Eigen::Matrix<T, 3, 1>& v) {
  Eigen::Matrix<T, 3, 3> s;
  s << T(0), -v.z(), v.y(), v.z(), T(0), -v.x(), -v.y(), v.x(), T(0);
  return s;
}

// The refinement's residuals for Ceres' TinySolver: one robust residual per correspondence, the
// five parameters a step from the start pose (rotation exp(w) * R0; translation t0 + B d, normalised,
// B an orthonormal basis of t0's tangent plane). TinySolver is Ceres' dense Levenberg-Marquardt for
// problems this small: the Problem it replaces built one residual block (a cost function and a
// loss) per correspondence and spent 70 % of a pair's two-view geometry there (ViSP's cube, 1700
// inliers a pair: 44 of 62 ms).
//
// Cauchy's loss enters the residual: r~ = sign(d) sqrt(rho(d^2)) with d the Sampson distance over
// `scale` and rho(s) = log(1 + s), so 0.5 |r~|^2 is the same objective Ceres minimised (up to its
// constant factor) and the minimum is the same.
struct RefinementResiduals {
  using Scalar = double;
  enum { NUM_RESIDUALS = Eigen::Dynamic, NUM_PARAMETERS = 5 };

  RefinementResiduals(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                      const Eigen::Matrix3d& rot, const Eigen::Vector3d& trans)
      : xi_(xi), xj_(xj), inv_scale_(1 / scale), rot_(rot), trans_(trans.normalized()) {
    // Any unit vector not parallel to t0 completes the basis.
    const Eigen::Vector3d helper = std::abs(trans_.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    basis_.col(0) = trans_.cross(helper).normalized();
    basis_.col(1) = trans_.cross(basis_.col(0));
  }
  int NumResiduals() const { return static_cast<int>(xi_.size()); }

  template <typename T>
  void Pose(const T* p, Eigen::Matrix<T, 3, 3>* rot, Eigen::Matrix<T, 3, 1>* trans) const {
    Eigen::Matrix<T, 3, 3> step;  // column-major, as ceres::AngleAxisToRotationMatrix writes it
    ceres::AngleAxisToRotationMatrix(p, step.data());
    *rot = step * rot_.cast<T>();
    const Eigen::Matrix<T, 3, 1> t = trans_.cast<T>() + basis_.col(0).cast<T>() * p[3] + basis_.col(1).cast<T>() * p[4];
    *trans = t / t.norm();
  }

  // residuals: (N); jacobian: (N x 5), column-major, or nullptr.
  bool operator()(const double* p, double* residuals, double* jacobian) const {
    using Jet = ceres::Jet<double, 5>;
    const int n = NumResiduals();
    if (jacobian == nullptr) {
      Eigen::Matrix3d rot;
      Eigen::Vector3d trans;
      Pose(p, &rot, &trans);
      const Eigen::Matrix3d e = SkewOf<double>(trans) * rot;
      for (int k = 0; k < n; ++k) residuals[k] = Robust(Sampson<double>(e, xi_[k], xj_[k]) * inv_scale_, nullptr);
      return true;
    }
    Jet pj[5];
    for (int a = 0; a < 5; ++a) pj[a] = Jet(p[a], a);
    Eigen::Matrix<Jet, 3, 3> rot;
    Eigen::Matrix<Jet, 3, 1> trans;
    Pose(pj, &rot, &trans);
    const Eigen::Matrix<Jet, 3, 3> e = SkewOf<Jet>(trans) * rot;  // once per evaluation, not per match
    for (int k = 0; k < n; ++k) {
      const Jet d = Sampson<Jet>(e, xi_[k], xj_[k]) * inv_scale_;
      double factor = 1;
      residuals[k] = Robust(d.a, &factor);
      for (int a = 0; a < 5; ++a) jacobian[a * n + k] = factor * d.v[a];
    }
    return true;
  }

  // sign(d) sqrt(log(1 + d^2)) and its derivative in d (1 at d = 0, its limit).
  static double Robust(double d, double* derivative) {
    const double s = d * d;
    const double r = std::copysign(std::sqrt(std::log1p(s)), d);
    if (derivative != nullptr) *derivative = std::abs(r) > 1e-12 ? d / ((1 + s) * r) : 1.0;
    return r;
  }

  const std::vector<Eigen::Vector2d>& xi_;
  const std::vector<Eigen::Vector2d>& xj_;
  double inv_scale_;
  Eigen::Matrix3d rot_;
  Eigen::Vector3d trans_;
  Eigen::Matrix<double, 3, 2> basis_;
};

}  // namespace

double SampsonDistance(const Eigen::Matrix3d& e, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj) {
  return Sampson<double>(e, xi, xj);
}

void RefineRelativePose(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        Eigen::Matrix3d* rot, Eigen::Vector3d* trans) {
  if (xi.size() < 5) return;
  const RefinementResiduals residuals(xi, xj, scale, *rot, *trans);
  ceres::TinySolver<RefinementResiduals> solver;
  solver.options.max_num_iterations = 30;
  // Ceres' Solver stops when the cost changes by less than 1e-6 of itself; TinySolver's tolerance
  // is absolute, so it is set from the starting cost.
  const double start_cost = 0.5 * RelativePoseCost(xi, xj, scale, *rot, *trans);
  solver.options.function_tolerance = 1e-6 * std::max(start_cost, 1e-12);
  Eigen::Matrix<double, 5, 1> p = Eigen::Matrix<double, 5, 1>::Zero();
  const auto& summary = solver.Solve(residuals, &p);
  if (!p.allFinite() || !(summary.final_cost <= summary.initial_cost)) return;
  Eigen::Matrix3d rot_refined;
  Eigen::Vector3d trans_refined;
  residuals.Pose(p.data(), &rot_refined, &trans_refined);
  // Orthonormal to rounding: through a quaternion, as the Problem's manifold kept it.
  *rot = Eigen::Quaterniond(rot_refined).normalized().toRotationMatrix();
  *trans = trans_refined.normalized();
}

double RelativePoseCost(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        const Eigen::Matrix3d& rot, const Eigen::Vector3d& trans) {
  const Eigen::Matrix3d e = SkewOf<double>(trans.normalized()) * rot;
  double cost = 0;
  for (size_t k = 0; k < xi.size(); ++k) cost += std::log1p(std::pow(Sampson<double>(e, xi[k], xj[k]) / scale, 2));
  return cost;
}

int RecoverPoseFromEssential(const Eigen::Matrix3d& e, const std::vector<Eigen::Vector2d>& xi,
                             const std::vector<Eigen::Vector2d>& xj, std::vector<uint8_t>* mask, Eigen::Matrix3d* rot,
                             Eigen::Vector3d* trans) {
  constexpr double kMaxDepth = 50;  // cv::recoverPose's distanceThresh default
  const int n = static_cast<int>(xi.size());
  cv::Mat e_cv, r1_cv, r2_cv, t_cv;
  cv::eigen2cv(e, e_cv);
  cv::decomposeEssentialMat(e_cv, r1_cv, r2_cv, t_cv);
  Eigen::Matrix3d r1, r2;
  Eigen::Vector3d t;
  cv::cv2eigen(r1_cv, r1);
  cv::cv2eigen(r2_cv, r2);
  cv::cv2eigen(t_cv, t);
  const std::array<Eigen::Matrix3d, 4> rots = {r1, r2, r1, r2};
  const std::array<Eigen::Vector3d, 4> transs = {t, t, -t, -t};
  std::array<std::vector<uint8_t>, 4> fronts;
  std::array<int, 4> counts = {0, 0, 0, 0};
  for (int h = 0; h < 4; ++h) {
    fronts[h].assign(n, 0);
    for (int k = 0; k < n; ++k) {
      if ((*mask)[k] == 0) continue;
      // d1 R x_i + t = d2 x_j in the least-squares sense: the two rays' closest points.
      const Eigen::Vector3d a = rots[h] * xi[k].homogeneous(), b = xj[k].homogeneous();
      const double aa = a.squaredNorm(), bb = b.squaredNorm(), ab = a.dot(b);
      const double at = a.dot(transs[h]), bt = b.dot(transs[h]);
      const double det = aa * bb - ab * ab;
      if (!(det > 1e-12 * aa * bb)) continue;  // parallel rays: a point at infinity, beyond kMaxDepth
      const double d1 = (-bb * at + ab * bt) / det, d2 = (-ab * at + aa * bt) / det;
      if (d1 > 0 && d2 > 0 && d1 < kMaxDepth && d2 < kMaxDepth) fronts[h][k] = 1, ++counts[h];
    }
  }
  // cv::recoverPose's choice: the first of the four with the largest count.
  int best = 0;
  for (int h = 1; h < 4; ++h)
    if (counts[h] > counts[best]) best = h;
  *rot = rots[best];
  *trans = transs[best];
  *mask = fronts[best];
  return counts[best];
}

}  // namespace nerfreg
