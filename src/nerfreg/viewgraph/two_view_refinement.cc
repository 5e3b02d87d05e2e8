#include "nerfreg/viewgraph/two_view_refinement.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <ceres/sphere_manifold.h>

#include <cmath>
#include <memory>
#include <Eigen/Geometry>

#include "nerfreg/posegraph/ceres_solve.h"

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

// One correspondence's Sampson distance as a function of j_from_i's rotation (Eigen quaternion:
// x, y, z, w) and unit translation.
struct SampsonCost {
  SampsonCost(const Eigen::Vector2d& xi, const Eigen::Vector2d& xj) : xi_(xi), xj_(xj) {}
  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    residual[0] = Sampson<T>(SkewOf<T>(translation) * rotation.toRotationMatrix(), xi_, xj_);
    return true;
  }
  Eigen::Vector2d xi_, xj_;
};

// The refinement's problem over q (x, y, z, w) and t (unit), both owned by the caller.
std::unique_ptr<ceres::Problem> MakeProblem(const std::vector<Eigen::Vector2d>& xi,
                                            const std::vector<Eigen::Vector2d>& xj, double scale, double* q,
                                            double* t) {
  auto problem = std::make_unique<ceres::Problem>();
  for (size_t k = 0; k < xi.size(); ++k)
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<SampsonCost, 1, 4, 3>(new SampsonCost(xi[k], xj[k])),
                              new ceres::CauchyLoss(scale), q, t);
  problem->SetManifold(q, new ceres::EigenQuaternionManifold);
  problem->SetManifold(t, new ceres::SphereManifold<3>);
  return problem;
}

}  // namespace

double SampsonDistance(const Eigen::Matrix3d& e, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj) {
  return Sampson<double>(e, xi, xj);
}

void RefineRelativePose(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        Eigen::Matrix3d* rot, Eigen::Vector3d* trans) {
  if (xi.size() < 5) return;
  Eigen::Quaterniond q(*rot);
  Eigen::Vector3d t = trans->normalized();
  const std::unique_ptr<ceres::Problem> problem = MakeProblem(xi, xj, scale, q.coeffs().data(), t.data());
  const ceres::Solver::Summary summary = SolveCeresProblem(problem.get(), 30, ceres::DENSE_QR);
  if (!summary.IsSolutionUsable()) return;
  *rot = q.normalized().toRotationMatrix();
  *trans = t.normalized();
}

double RelativePoseCost(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        const Eigen::Matrix3d& rot, const Eigen::Vector3d& trans) {
  if (xi.empty()) return 0;
  Eigen::Quaterniond q(rot);
  Eigen::Vector3d t = trans.normalized();
  const std::unique_ptr<ceres::Problem> problem = MakeProblem(xi, xj, scale, q.coeffs().data(), t.data());
  double cost = 0;
  problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
  // Ceres' cost is sum 0.5 * rho(d^2), with CauchyLoss's rho(s) = scale^2 * log(1 + s / scale^2).
  return 2 * cost / (scale * scale);
}

}  // namespace nerfreg
