#include "nerfreg/viewgraph/two_view_refinement.h"

#include <cmath>
#include <Eigen/Geometry>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

double SampsonDistance(const Eigen::Matrix3d& e, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj) {
  const Eigen::Vector3d a = xi.homogeneous(), b = xj.homogeneous();
  const Eigen::Vector3d ea = e * a, eb = e.transpose() * b;
  const double den = ea.head<2>().squaredNorm() + eb.head<2>().squaredNorm();
  return den > 0 ? b.dot(ea) / std::sqrt(den) : 0;
}

void RefineRelativePose(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        Eigen::Matrix3d* rot, Eigen::Vector3d* trans) {
  const int n = static_cast<int>(xi.size());
  if (n < 5) return;
  const double c2 = scale * scale;
  auto residuals = [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& t, Eigen::VectorXd* out) {
    const Eigen::Matrix3d e = Skew(t) * r;
    out->resize(n);
    for (int k = 0; k < n; ++k) (*out)(k) = SampsonDistance(e, xi[k], xj[k]);
  };
  auto cost = [&](const Eigen::VectorXd& res) {
    double sum = 0;
    for (int k = 0; k < n; ++k) sum += std::log1p(res(k) * res(k) / c2);
    return sum;
  };
  auto apply = [](const Eigen::Matrix3d& r, const Eigen::Vector3d& t, const Eigen::Matrix<double, 5, 1>& d,
                  Eigen::Matrix3d* r_out, Eigen::Vector3d* t_out) {
    const Eigen::Vector3d w = d.head<3>();
    const double angle = w.norm();
    const Eigen::Matrix3d dr =
        angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    *r_out = dr * r;
    // The tangent plane of the unit sphere at t: two unit vectors orthogonal to it.
    Eigen::Vector3d b1 = t.unitOrthogonal(), b2 = t.cross(b1);
    *t_out = (t + d(3) * b1 + d(4) * b2).normalized();
  };
  Eigen::Matrix3d r = *rot;
  Eigen::Vector3d t = trans->normalized();
  Eigen::VectorXd res, res_step;
  residuals(r, t, &res);
  double current = cost(res);
  double lambda = 1e-3;
  Eigen::MatrixXd jac(n, 5);
  for (int iteration = 0; iteration < 30; ++iteration) {
    constexpr double kStep = 1e-7;
    for (int p = 0; p < 5; ++p) {
      Eigen::Matrix<double, 5, 1> d = Eigen::Matrix<double, 5, 1>::Zero();
      d(p) = kStep;
      Eigen::Matrix3d rp;
      Eigen::Vector3d tp;
      apply(r, t, d, &rp, &tp);
      residuals(rp, tp, &res_step);
      jac.col(p) = (res_step - res) / kStep;
    }
    // Cauchy weights: the Gauss-Newton system of sum log(1 + r^2 / c^2).
    const Eigen::VectorXd w = (1.0 + res.array().square() / c2).inverse().matrix();
    const Eigen::Matrix<double, 5, 5> jtj = jac.transpose() * w.asDiagonal() * jac;
    const Eigen::Matrix<double, 5, 1> jtr = jac.transpose() * w.cwiseProduct(res);
    bool improved = false;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      Eigen::Matrix<double, 5, 5> a = jtj;
      a.diagonal() += lambda * jtj.diagonal().cwiseMax(1e-12);
      const Eigen::Matrix<double, 5, 1> d = a.ldlt().solve(-jtr);
      Eigen::Matrix3d rn;
      Eigen::Vector3d tn;
      apply(r, t, d, &rn, &tn);
      residuals(rn, tn, &res_step);
      const double next = cost(res_step);
      if (next < current) {
        improved = true;
        const double gain = current - next;
        r = rn, t = tn, res = res_step, current = next;
        lambda = std::max(lambda / 10, 1e-9);
        if (gain < 1e-10 * (1 + current)) iteration = 30;  // converged
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  *rot = r;
  *trans = t;
}

double RelativePoseCost(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        const Eigen::Matrix3d& rot, const Eigen::Vector3d& trans) {
  const Eigen::Matrix3d e = Skew(trans.normalized()) * rot;
  double sum = 0;
  for (size_t k = 0; k < xi.size(); ++k) {
    const double r = SampsonDistance(e, xi[k], xj[k]) / scale;
    sum += std::log1p(r * r);
  }
  return sum;
}

}  // namespace nerfreg
