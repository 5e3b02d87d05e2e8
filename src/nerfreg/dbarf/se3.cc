#include "nerfreg/dbarf/se3.h"

#include <cmath>

namespace nerfreg {
namespace {

// Below this squared angle the closed forms lose precision; use Taylor series (to theta^6).
double SmallAngle2(const torch::Tensor& t) { return t.scalar_type() == torch::kDouble ? 1e-2 : 9e-2; }

torch::Tensor Eye3Like(const torch::Tensor& t) { return torch::eye(3, t.options()); }

// Squared norm of the last dimension and a "safe" angle (1 where the series branch is used), so
// that neither branch of a torch::where produces inf/nan gradients.
struct Angle {
  torch::Tensor theta2;  // [...]
  torch::Tensor small;   // [...] bool
  torch::Tensor theta;   // [...], 1 where small
};

Angle AngleOf(const torch::Tensor& omega) {
  Angle a;
  a.theta2 = (omega * omega).sum(-1);
  a.small = a.theta2 < SmallAngle2(omega);
  a.theta = torch::sqrt(torch::where(a.small, torch::ones_like(a.theta2), a.theta2));
  return a;
}

// Coefficients of Exp: A = sin/t, B = (1 - cos)/t^2, C = (t - sin)/t^3.
void ExpCoefficients(const Angle& a, torch::Tensor* ca, torch::Tensor* cb, torch::Tensor* cc) {
  const torch::Tensor t2 = a.theta2, t4 = t2 * t2, t6 = t4 * t2;
  const torch::Tensor s = torch::sin(a.theta), c = torch::cos(a.theta);
  const torch::Tensor th2 = a.theta * a.theta;
  *ca = torch::where(a.small, 1.0 - t2 / 6.0 + t4 / 120.0 - t6 / 5040.0, s / a.theta);
  *cb = torch::where(a.small, 0.5 - t2 / 24.0 + t4 / 720.0 - t6 / 40320.0, (1.0 - c) / th2);
  *cc = torch::where(a.small, 1.0 / 6.0 - t2 / 120.0 + t4 / 5040.0 - t6 / 362880.0, (a.theta - s) / (th2 * a.theta));
}

torch::Tensor Vee(const torch::Tensor& m) {
  return torch::stack({m.select(-1, 1).select(-1, 2), m.select(-1, 2).select(-1, 0), m.select(-1, 0).select(-1, 1)},
                      -1);
}

torch::Tensor MakeTransform(const torch::Tensor& rotation, const torch::Tensor& translation) {
  auto sizes = rotation.sizes().vec();
  sizes.back() = 4;
  sizes[sizes.size() - 2] = 1;
  torch::Tensor bottom = torch::zeros(sizes, rotation.options());
  bottom.select(-1, 3).fill_(1.0);
  const torch::Tensor top = torch::cat({rotation, translation.unsqueeze(-1)}, -1);
  return torch::cat({top, bottom}, -2);
}

void CheckTransform(const torch::Tensor& t, const char* name) {
  TORCH_CHECK(t.dim() >= 2 && t.size(-1) == 4 && t.size(-2) == 4, name, ": expected [..., 4, 4], got ", t.sizes());
  TORCH_CHECK(t.is_floating_point(), name, ": expected a floating dtype");
}

}  // namespace

torch::Tensor So3Hat(const torch::Tensor& omega) {
  TORCH_CHECK(omega.dim() >= 1 && omega.size(-1) == 3, "So3Hat: expected [..., 3], got ", omega.sizes());
  const torch::Tensor x = omega.select(-1, 0), y = omega.select(-1, 1), z = omega.select(-1, 2);
  const torch::Tensor o = torch::zeros_like(x);
  auto sizes = omega.sizes().vec();
  sizes.back() = 3;
  sizes.push_back(3);
  return torch::stack({o, -z, y, z, o, -x, -y, x, o}, -1).view(sizes);
}

torch::Tensor So3Exp(const torch::Tensor& omega) {
  TORCH_CHECK(omega.dim() >= 1 && omega.size(-1) == 3, "So3Exp: expected [..., 3], got ", omega.sizes());
  const Angle a = AngleOf(omega);
  torch::Tensor ca, cb, cc;
  ExpCoefficients(a, &ca, &cb, &cc);
  const torch::Tensor w = So3Hat(omega);
  return Eye3Like(omega) + ca.unsqueeze(-1).unsqueeze(-1) * w + cb.unsqueeze(-1).unsqueeze(-1) * torch::matmul(w, w);
}

torch::Tensor So3Log(const torch::Tensor& rotation) {
  TORCH_CHECK(rotation.dim() >= 2 && rotation.size(-1) == 3 && rotation.size(-2) == 3,
              "So3Log: expected [..., 3, 3], got ", rotation.sizes());
  // v = sin(theta) n, c = cos(theta).
  const torch::Tensor v = 0.5 * Vee(rotation - rotation.transpose(-1, -2));
  const torch::Tensor c = 0.5 * (rotation.diagonal(0, -2, -1).sum(-1) - 1.0);
  const torch::Tensor v2 = (v * v).sum(-1);
  const torch::Tensor positive = v2 > 0;
  const torch::Tensor sin_theta =
      torch::where(positive, torch::sqrt(torch::where(positive, v2, torch::ones_like(v2))), torch::zeros_like(v2));
  const torch::Tensor theta = torch::atan2(sin_theta, c);
  const torch::Tensor t2 = theta * theta;
  const torch::Tensor small = t2 < SmallAngle2(rotation);
  // Small angles: theta / sin(theta) = 1 + t^2/6 + 7 t^4/360 + ...
  const torch::Tensor small_scale = 1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0;
  const torch::Tensor near_pi = c < -0.9;
  const torch::Tensor general_ok = torch::logical_and(torch::logical_not(small), torch::logical_not(near_pi));
  const torch::Tensor safe_sin = torch::where(general_ok, sin_theta, torch::ones_like(sin_theta));
  const torch::Tensor general_scale = theta / safe_sin;
  torch::Tensor omega = v * torch::where(general_ok, general_scale, small_scale).unsqueeze(-1);

  // Near pi: (R + R^T)/2 - c I = (1 - c) n n^T; take the column with the largest diagonal.
  const torch::Tensor sym =
      0.5 * (rotation + rotation.transpose(-1, -2)) - c.unsqueeze(-1).unsqueeze(-1) * Eye3Like(rotation);
  const torch::Tensor one_minus_c = torch::where(near_pi, 1.0 - c, torch::ones_like(c));
  const torch::Tensor nn = sym / one_minus_c.unsqueeze(-1).unsqueeze(-1);
  const torch::Tensor diag = nn.diagonal(0, -2, -1);          // [..., 3]
  const torch::Tensor k = diag.argmax(-1, /*keepdim=*/true);  // [..., 1]
  const torch::Tensor col = torch::gather(nn, -1, k.unsqueeze(-2).expand_as(nn.narrow(-1, 0, 1))).squeeze(-1);
  const torch::Tensor dk = torch::gather(diag, -1, k).squeeze(-1).clamp_min(1e-12);
  torch::Tensor axis = col / torch::sqrt(dk).unsqueeze(-1);
  const torch::Tensor sign = torch::where((axis * v).sum(-1) < 0, -torch::ones_like(c), torch::ones_like(c));
  axis = axis * sign.unsqueeze(-1);
  return torch::where(near_pi.unsqueeze(-1), axis * theta.unsqueeze(-1), omega);
}

torch::Tensor Se3Exp(const torch::Tensor& xi) {
  TORCH_CHECK(xi.dim() >= 1 && xi.size(-1) == 6, "Se3Exp: expected [..., 6], got ", xi.sizes());
  TORCH_CHECK(xi.is_floating_point(), "Se3Exp: expected a floating dtype");
  const torch::Tensor rho = xi.narrow(-1, 0, 3), omega = xi.narrow(-1, 3, 3);
  const Angle a = AngleOf(omega);
  torch::Tensor ca, cb, cc;
  ExpCoefficients(a, &ca, &cb, &cc);
  const torch::Tensor w = So3Hat(omega), w2 = torch::matmul(w, w);
  const torch::Tensor eye = Eye3Like(xi);
  const auto u = [](const torch::Tensor& s) { return s.unsqueeze(-1).unsqueeze(-1); };
  const torch::Tensor rotation = eye + u(ca) * w + u(cb) * w2;
  const torch::Tensor v = eye + u(cb) * w + u(cc) * w2;
  return MakeTransform(rotation, torch::matmul(v, rho.unsqueeze(-1)).squeeze(-1));
}

torch::Tensor Se3Log(const torch::Tensor& transform) {
  CheckTransform(transform, "Se3Log");
  const torch::Tensor rotation = transform.narrow(-2, 0, 3).narrow(-1, 0, 3);
  const torch::Tensor t = transform.narrow(-2, 0, 3).select(-1, 3);
  const torch::Tensor omega = So3Log(rotation);
  const Angle a = AngleOf(omega);
  // V^-1 = I - W/2 + D W^2, D = (1 - theta sin / (2 (1 - cos))) / theta^2.
  const torch::Tensor t2 = a.theta2;
  const torch::Tensor th2 = a.theta * a.theta;
  const torch::Tensor d_general = (1.0 - a.theta * torch::sin(a.theta) / (2.0 * (1.0 - torch::cos(a.theta)))) / th2;
  const torch::Tensor d = torch::where(a.small, 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0, d_general);
  const torch::Tensor w = So3Hat(omega);
  const torch::Tensor v_inv = Eye3Like(transform) - 0.5 * w + d.unsqueeze(-1).unsqueeze(-1) * torch::matmul(w, w);
  const torch::Tensor rho = torch::matmul(v_inv, t.unsqueeze(-1)).squeeze(-1);
  return torch::cat({rho, omega}, -1);
}

torch::Tensor Se3Compose(const torch::Tensor& a_from_b, const torch::Tensor& b_from_c) {
  CheckTransform(a_from_b, "Se3Compose");
  CheckTransform(b_from_c, "Se3Compose");
  return torch::matmul(a_from_b, b_from_c);
}

torch::Tensor Se3Inverse(const torch::Tensor& b_from_a) {
  CheckTransform(b_from_a, "Se3Inverse");
  const torch::Tensor rt = b_from_a.narrow(-2, 0, 3).narrow(-1, 0, 3).transpose(-1, -2);
  const torch::Tensor t = b_from_a.narrow(-2, 0, 3).select(-1, 3);
  return MakeTransform(rt, -torch::matmul(rt, t.unsqueeze(-1)).squeeze(-1));
}

torch::Tensor Se3Apply(const torch::Tensor& b_from_a, const torch::Tensor& x_in_a) {
  CheckTransform(b_from_a, "Se3Apply");
  TORCH_CHECK(x_in_a.dim() >= 2 && x_in_a.size(-1) == 3, "Se3Apply: expected points [..., P, 3], got ", x_in_a.sizes());
  const torch::Tensor r = b_from_a.narrow(-2, 0, 3).narrow(-1, 0, 3);
  const torch::Tensor t = b_from_a.narrow(-2, 0, 3).select(-1, 3);
  return torch::matmul(x_in_a, r.transpose(-1, -2)) + t.unsqueeze(-2);
}

torch::Tensor RelativeTransform(const torch::Tensor& b_from_world, const torch::Tensor& a_from_world) {
  return Se3Compose(b_from_world, Se3Inverse(a_from_world));
}

torch::Tensor Se3Update(const torch::Tensor& delta, const torch::Tensor& transform) {
  CheckTransform(transform, "Se3Update");
  return torch::matmul(Se3Exp(delta.to(transform.scalar_type())), transform);
}

torch::Tensor So3GeodesicAngle(const torch::Tensor& a, const torch::Tensor& b) {
  TORCH_CHECK(a.dim() >= 2 && b.dim() >= 2 && a.size(-1) == a.size(-2) && b.size(-1) == b.size(-2) && a.size(-1) >= 3 &&
                  b.size(-1) >= 3,
              "So3GeodesicAngle: expected [..., 3, 3] or [..., 4, 4]");
  const torch::Tensor ra = a.narrow(-2, 0, 3).narrow(-1, 0, 3);
  const torch::Tensor rb = b.narrow(-2, 0, 3).narrow(-1, 0, 3);
  const torch::Tensor rel = torch::matmul(ra.transpose(-1, -2), rb);
  const torch::Tensor s = Vee(rel - rel.transpose(-1, -2)).norm(2, -1) * 0.5;
  const torch::Tensor c = 0.5 * (rel.diagonal(0, -2, -1).sum(-1) - 1.0);
  return torch::atan2(s, c);
}

}  // namespace nerfreg
