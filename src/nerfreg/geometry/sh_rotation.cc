#include "nerfreg/geometry/sh_rotation.h"

#include <Eigen/QR>
#include <cmath>
#include <stdexcept>

namespace nerfreg {

namespace {
// 3DGS's constants (utils/sh_utils.py).
constexpr double kC0 = 0.28209479177387814;
constexpr double kC1 = 0.4886025119029199;
constexpr double kC2[] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
                          0.5462742152960396};
constexpr double kC3[] = {-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
                          -0.4570457994644658, 1.445305721320277, -0.5900435899266435};
constexpr int kSampleDirections = 32;
}  // namespace

Eigen::VectorXd RealShBasis(const Eigen::Vector3d& d, int degree) {
  if (degree < 0 || degree > 3) throw std::invalid_argument("RealShBasis: degree must be 0..3");
  Eigen::VectorXd y((degree + 1) * (degree + 1));
  const double x = d.x(), yy = d.y(), z = d.z();
  y(0) = kC0;
  if (degree >= 1) {
    y(1) = -kC1 * yy;
    y(2) = kC1 * z;
    y(3) = -kC1 * x;
  }
  if (degree >= 2) {
    const double xx = x * x, ys = yy * yy, zz = z * z;
    y(4) = kC2[0] * x * yy;
    y(5) = kC2[1] * yy * z;
    y(6) = kC2[2] * (2 * zz - xx - ys);
    y(7) = kC2[3] * x * z;
    y(8) = kC2[4] * (xx - ys);
    if (degree >= 3) {
      y(9) = kC3[0] * yy * (3 * xx - ys);
      y(10) = kC3[1] * x * yy * z;
      y(11) = kC3[2] * yy * (4 * zz - xx - ys);
      y(12) = kC3[3] * z * (2 * zz - 3 * xx - 3 * ys);
      y(13) = kC3[4] * x * (4 * zz - xx - ys);
      y(14) = kC3[5] * z * (xx - ys);
      y(15) = kC3[6] * x * (xx - 3 * ys);
    }
  }
  return y;
}

Eigen::MatrixXd ShRotationMatrix(const Eigen::Matrix3d& rotation, int degree) {
  if (degree < 0 || degree > 3) throw std::invalid_argument("ShRotationMatrix: degree must be 0..3");
  const int n = (degree + 1) * (degree + 1);
  // Rows: Y(d_j)^T and Y(R^T d_j)^T over a Fibonacci sphere (well spread, fixed).
  Eigen::MatrixXd a(kSampleDirections, n), b(kSampleDirections, n);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int j = 0; j < kSampleDirections; ++j) {
    const double z = 1.0 - 2.0 * (j + 0.5) / kSampleDirections, r = std::sqrt(1.0 - z * z);
    const Eigen::Vector3d d(r * std::cos(golden * j), r * std::sin(golden * j), z);
    a.row(j) = RealShBasis(d, degree).transpose();
    b.row(j) = RealShBasis(rotation.transpose() * d, degree).transpose();
  }
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
  for (int l = 0; l <= degree; ++l) {
    const int first = l * l, size = 2 * l + 1;
    m.block(first, first, size, size) =
        a.middleCols(first, size).colPivHouseholderQr().solve(b.middleCols(first, size));
  }
  return m;
}

}  // namespace nerfreg
