#pragma once
// Rigid and similarity transforms, named by direction: `b_from_a` maps points in frame a to
// frame b, x_in_b = b_from_a * x_in_a. Composition reads right to left:
// c_from_a = c_from_b * b_from_a.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace nerfreg {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix3x4d = Eigen::Matrix<double, 3, 4>;

// x_in_b = rotation * x_in_a + translation.
struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& r, const Eigen::Vector3d& t) : rotation(r.normalized()), translation(t) {}
  Rigid3d(const Eigen::Matrix3d& r, const Eigen::Vector3d& t);

  // From a 3x4 or 4x4 [R|t]. Throws std::invalid_argument if R is not a rotation
  // (orthonormality or determinant off by more than `tol`).
  static Rigid3d FromMatrix(const Eigen::Matrix4d& m, double tol = 1e-4);
  static Rigid3d FromMatrix(const Matrix3x4d& m, double tol = 1e-4);

  Eigen::Matrix4d ToMatrix() const;  // homogeneous 4x4
  Matrix3x4d ToMatrix3x4() const;
  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }

  Rigid3d Inverse() const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return rotation * x + translation; }
  Rigid3d operator*(const Rigid3d& other) const;

  // SE(3) exponential / logarithm with xi = [omega (rotation vector, rad); v], using the
  // left-Jacobian so that Exp(Log(T)) == T and the translation part is coupled as on the manifold.
  static Rigid3d Exp(const Vector6d& xi);
  Vector6d Log() const;
};

// The scales nerfreg reads or returns (a block's world_from_field, T.json, a registration's
// result): outside them a file is refused as a wrong unit or a broken file, since no two captures
// of one object differ in size by more than a thousand times.
inline constexpr double kMinSim3Scale = 1e-3;
inline constexpr double kMaxSim3Scale = 1e3;

// x_in_b = scale * rotation * x_in_a + translation.
struct Sim3d {
  double scale = 1.0;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Sim3d() = default;
  Sim3d(double s, const Eigen::Quaterniond& r, const Eigen::Vector3d& t)
      : scale(s), rotation(r.normalized()), translation(t) {}
  explicit Sim3d(const Rigid3d& rigid) : scale(1.0), rotation(rigid.rotation), translation(rigid.translation) {}

  // From a 4x4 [sR|t; 0 0 0 1]; the scale is the cube root of det(sR). Throws
  // std::invalid_argument if sR / s is not a rotation or s <= 0.
  static Sim3d FromMatrix(const Eigen::Matrix4d& m, double tol = 1e-4);
  Eigen::Matrix4d ToMatrix() const;
  Rigid3d ToRigid() const { return Rigid3d(rotation, translation); }  // drops the scale

  Sim3d Inverse() const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return scale * (rotation * x) + translation; }
  // Every column of x [3, N] moved.
  Eigen::Matrix3Xd TransformPoints(const Eigen::Matrix3Xd& x) const {
    return ((scale * rotation.toRotationMatrix()) * x).colwise() + translation;
  }
  Sim3d operator*(const Sim3d& other) const;

  // Moves a camera by this transform: given cam_from_a, returns cam_from_b where b = this * a.
  // The camera keeps its intrinsics; its centre moves by the Sim3 and its orientation by the
  // rotation, so the returned pose is rigid (a scale changes distances in b, not the camera).
  Rigid3d TransformCamera(const Rigid3d& cam_from_a) const;
};

// Geodesic angle between two rotations, degrees, in [0, 180].
double RotationErrorDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);
double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
// Full Euclidean norm of the translation difference (not |dx| alone; see dreg-nerf.md 9.5).
double TranslationError(const Eigen::Vector3d& a, const Eigen::Vector3d& b);
// Angle between two directions, degrees, in [0, 180]; 180 when either is zero (no direction
// agrees with it).
double DirectionAngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

// Skew-symmetric matrix of v: Skew(v) * x == v.cross(x).
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);

// Uniformly random rotation (Shoemake) from three uniforms in [0, 1).
Eigen::Quaterniond RandomRotation(double u1, double u2, double u3);

}  // namespace nerfreg
