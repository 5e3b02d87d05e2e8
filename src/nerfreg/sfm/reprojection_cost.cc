#include "nerfreg/sfm/reprojection_cost.h"

#include <Eigen/Core>
#include <limits>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

ReprojectionCost::ReprojectionCost(const Eigen::Vector2d& uv, const Camera& camera, bool refine_intrinsics)
    : r_(uv, camera), refine_intrinsics_(refine_intrinsics) {
  set_num_residuals(2);
  mutable_parameter_block_sizes()->push_back(6);
  mutable_parameter_block_sizes()->push_back(3);
  if (refine_intrinsics) mutable_parameter_block_sizes()->push_back(3);
}

bool ReprojectionCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* camera = parameters[0];
  const Eigen::Map<const Eigen::Vector3d> w(camera), t(camera + 3), x(parameters[1]);
  const double focal = refine_intrinsics_ ? parameters[2][0] : r_.fx;
  const double k1 = refine_intrinsics_ ? parameters[2][1] : r_.k1;
  const double k2 = refine_intrinsics_ ? parameters[2][2] : r_.k2;

  // p = R(w) x + t. Below theta^2 = machine epsilon the rotation is first order, as
  // ceres::AngleAxisRotatePoint has it.
  Eigen::Matrix3d rotation;
  const double theta2 = w.squaredNorm();
  const bool first_order = !(theta2 > std::numeric_limits<double>::epsilon());
  if (first_order)
    rotation = Eigen::Matrix3d::Identity() + Skew(Eigen::Vector3d(w));
  else
    ceres::AngleAxisToRotationMatrix(camera, ceres::ColumnMajorAdapter3x3(rotation.data()));
  const Eigen::Vector3d rx = first_order ? Eigen::Vector3d(x + w.cross(x)) : Eigen::Vector3d(rotation * x);
  const Eigen::Vector3d p = rx + t;
  const bool clamped = !(p.z() > 1e-6);
  const double z = clamped ? 1e-6 : p.z();
  const double u = p.x() / z, v = p.y() / z;
  const double r2 = u * u + v * v;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * (r_.k3 + r2 * r_.k4)));
  const double ud = u * radial + 2 * r_.p1 * u * v + r_.p2 * (r2 + 2 * u * u);
  const double vd = v * radial + r_.p1 * (r2 + 2 * v * v) + 2 * r_.p2 * u * v;
  residuals[0] = focal * ud + r_.cx - r_.uv.x();
  residuals[1] = focal * r_.aspect * vd + r_.cy - r_.uv.y();
  if (jacobians == nullptr) return true;

  // d(residual)/dp = diag(f, f aspect) * d(ud, vd)/d(u, v) * d(u, v)/dp.
  const double d_radial = k1 + r2 * (2 * k2 + r2 * (3 * r_.k3 + r2 * 4 * r_.k4));  // d radial / d r2
  Eigen::Matrix2d distortion;
  distortion(0, 0) = radial + 2 * u * u * d_radial + 2 * r_.p1 * v + 6 * r_.p2 * u;
  distortion(0, 1) = 2 * u * v * d_radial + 2 * r_.p1 * u + 2 * r_.p2 * v;
  distortion(1, 0) = distortion(0, 1);
  distortion(1, 1) = radial + 2 * v * v * d_radial + 6 * r_.p1 * v + 2 * r_.p2 * u;
  Eigen::Matrix<double, 2, 3> projection;
  projection << 1 / z, 0, clamped ? 0 : -u / z, 0, 1 / z, clamped ? 0 : -v / z;
  Eigen::Matrix<double, 2, 3> d_p = distortion * projection;
  d_p.row(0) *= focal;
  d_p.row(1) *= focal * r_.aspect;
  if (jacobians[0] != nullptr) {
    // dp/dw = -[R x]_x J_l(w), J_l the left Jacobian of SO(3) (first order: -[x]_x).
    Eigen::Matrix3d dp_dw;
    if (first_order) {
      dp_dw = -Skew(Eigen::Vector3d(x));
    } else {
      const double theta = std::sqrt(theta2);
      const Eigen::Matrix3d sw = Skew(Eigen::Vector3d(w));
      dp_dw = -Skew(rx) * (Eigen::Matrix3d::Identity() + (1 - std::cos(theta)) / theta2 * sw +
                           (theta - std::sin(theta)) / (theta2 * theta) * sw * sw);
    }
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> j(jacobians[0]);
    j.leftCols<3>() = d_p * dp_dw;
    j.rightCols<3>() = d_p;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
    j = d_p * rotation;
  }
  if (refine_intrinsics_ && jacobians[2] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[2]);
    j << ud, focal * u * r2, focal * u * r2 * r2, r_.aspect * vd, focal * r_.aspect * v * r2,
        focal * r_.aspect * v * r2 * r2;
  }
  return true;
}

}  // namespace nerfreg
