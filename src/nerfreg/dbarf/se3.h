// Batched, differentiable SE(3) / SO(3) maps on LibTorch tensors, for pose updates on the manifold
// (DBARF's pose network and the photometric pose refinement; spec dbarf.md 3 recommends se(3)
// updates in place of the original's additive Euler angles).
//
// Conventions:
//  - A twist xi is a [..., 6] tensor ordered (rho, omega): translation part first, then the
//    rotation vector (axis * angle, radians). Exp(xi) = [[R, V rho], [0, 1]].
//  - A rigid transform is a [..., 4, 4] homogeneous matrix b_from_a with x_in_b = R x_in_a + t.
//  - Updates are left-multiplicative: T <- Exp(delta) * T (delta expressed in T's output frame).
//  - Any floating dtype and device; the leading batch dimensions "..." may be empty.
//
// Stability: Exp and Log switch to Taylor series below a small angle, written so that the gradient
// is finite (and exact) at xi = 0. Log uses atan2 for the angle and a dedicated branch near pi,
// where the antisymmetric part of R vanishes.
#pragma once

#include <torch/torch.h>

namespace nerfreg {

// [..., 3] -> [..., 3, 3] skew-symmetric matrix: Hat(w) x = w x (cross product).
torch::Tensor So3Hat(const torch::Tensor& omega);

// Rotation vector [..., 3] -> rotation matrix [..., 3, 3] (Rodrigues).
torch::Tensor So3Exp(const torch::Tensor& omega);

// Rotation matrix [..., 3, 3] -> rotation vector [..., 3] with angle in [0, pi].
torch::Tensor So3Log(const torch::Tensor& rotation);

// Twist [..., 6] (rho, omega) -> transform [..., 4, 4].
torch::Tensor Se3Exp(const torch::Tensor& xi);

// Transform [..., 4, 4] (last row [0, 0, 0, 1]) -> twist [..., 6] (rho, omega).
torch::Tensor Se3Log(const torch::Tensor& transform);

// a_from_b [..., 4, 4] * b_from_c [..., 4, 4] -> a_from_c [..., 4, 4] (broadcasting batch dims).
torch::Tensor Se3Compose(const torch::Tensor& a_from_b, const torch::Tensor& b_from_c);

// b_from_a [..., 4, 4] -> a_from_b [..., 4, 4] (closed form R^T, -R^T t; no matrix inverse).
torch::Tensor Se3Inverse(const torch::Tensor& b_from_a);

// b_from_a [..., 4, 4] applied to x_in_a [..., P, 3] -> x_in_b [..., P, 3].
torch::Tensor Se3Apply(const torch::Tensor& b_from_a, const torch::Tensor& x_in_a);

// b_from_a = b_from_world * a_from_world^-1 for cameras posed as cam_from_world [..., 4, 4]: the
// src_from_tgt of a pair is RelativeTransform(src_from_world, tgt_from_world).
torch::Tensor RelativeTransform(const torch::Tensor& b_from_world, const torch::Tensor& a_from_world);

// The left update Exp(delta) * transform: delta [..., 6], transform [..., 4, 4] -> [..., 4, 4].
torch::Tensor Se3Update(const torch::Tensor& delta, const torch::Tensor& transform);

// Geodesic angle (radians, [0, pi]) between rotations [..., 3, 3]: angle of a^T b -> [...].
// Accepts [..., 4, 4] transforms too (their rotation blocks are compared).
torch::Tensor So3GeodesicAngle(const torch::Tensor& a, const torch::Tensor& b);

}  // namespace nerfreg
