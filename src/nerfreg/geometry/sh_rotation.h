#pragma once
// Real spherical harmonics of degrees 0-3 as 3D Gaussian splatting evaluates them (its
// utils/sh_utils.py eval_sh: the orthonormal real basis with its constants and signs, e.g.
// Y_1 = (-C1 y, C1 z, -C1 x)), and their rotation.
//
// A splat's colour seen along unit direction d (from the camera to the splat) is
// f(d) = sum_k c_k Y_k(d) (+ 0.5, per channel). Moving the splat by a rotation R turns the
// direction it was seen from into R d, so the moved splat's colour function is g(d) = f(R^T d).
// Each degree's functions span a space closed under rotation, so g = sum_k c'_k Y_k with c' = M c
// for a block-diagonal M (one orthogonal block per degree: the Wigner D-matrix in this basis).
//
// M is found by least squares on fixed sample directions d_j. g(d) = c^T Y(R^T d) = (M c)^T Y(d)
// for every c gives Y(R^T d_j)^T = Y(d_j)^T M: per degree, 32 rows of 2l + 1 unknowns, solved by
// QR, exact up to rounding because the space is closed. Simpler to get right than a recursion
// whose sign conventions must match 3DGS's basis; the tests check it against a brute-force
// evaluation of f at rotated directions.
#include <Eigen/Core>

namespace nerfreg {

// The (degree + 1)^2 basis functions at unit direction d, in 3DGS's order. degree in 0..3.
Eigen::VectorXd RealShBasis(const Eigen::Vector3d& d, int degree);

// M, [(degree + 1)^2, (degree + 1)^2], block-diagonal and orthogonal: the coefficients of
// g(d) = f(R^T d) are M c. `rotation` must be a rotation matrix; degree in 0..3.
Eigen::MatrixXd ShRotationMatrix(const Eigen::Matrix3d& rotation, int degree);

}  // namespace nerfreg
