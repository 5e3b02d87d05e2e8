#include "nerfreg/util/torch_device.h"  // torch::linalg under LibTorch 2.x
#include "nerfreg/dbarf/se3.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace nerfreg {
namespace {

class Se3Test : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(1);
    torch::manual_seed(3);
  }
};

// Twists with rotation angles from 0 to just below pi along random axes.
torch::Tensor TestTwists(torch::Dtype dtype) {
  const std::vector<double> angles = {0.0, 1e-9, 1e-5, 1e-3, 0.05,        0.29,       0.31,
                                      0.5, 1.5,  2.5,  3.0,  M_PI - 1e-3, M_PI - 1e-6};
  const int64_t n = static_cast<int64_t>(angles.size());
  torch::Tensor axis = torch::randn({n, 3}, torch::kDouble);
  axis = axis / axis.norm(2, 1, true);
  const torch::Tensor omega = axis * torch::tensor(angles, torch::kDouble).unsqueeze(1);
  const torch::Tensor rho = torch::randn({n, 3}, torch::kDouble);
  return torch::cat({rho, omega}, 1).to(dtype);
}

TEST_F(Se3Test, ExpOfLogIsIdentityIncludingTinyAndNearPiAngles) {
  for (const auto dtype : {torch::kDouble, torch::kFloat}) {
    const double tol = dtype == torch::kDouble ? 1e-9 : 2e-5;
    const torch::Tensor t = Se3Exp(TestTwists(dtype));
    const torch::Tensor round_trip = Se3Exp(Se3Log(t));
    EXPECT_LT((round_trip - t).abs().max().item<double>(), tol) << dtype;
    // Rotations stay orthonormal with determinant 1.
    const torch::Tensor r = t.slice(1, 0, 3).slice(2, 0, 3);
    const torch::Tensor rtr = torch::matmul(r.transpose(1, 2), r);
    EXPECT_LT((rtr - torch::eye(3, r.options())).abs().max().item<double>(), 10 * tol);
    EXPECT_LT((torch::linalg::det(r) - 1.0).abs().max().item<double>(), 10 * tol);
  }
}

TEST_F(Se3Test, LogOfExpRecoversTheTwistBelowPi) {
  const torch::Tensor xi = TestTwists(torch::kDouble);
  const torch::Tensor back = Se3Log(Se3Exp(xi));
  // Near pi the axis is recovered from the symmetric part (precision ~ sqrt(eps) at pi - 1e-6).
  EXPECT_LT((back - xi).abs().slice(0, 0, xi.size(0) - 1).max().item<double>(), 1e-8);
  EXPECT_LT((back - xi).abs().max().item<double>(), 1e-5);
  // Random rotations (any angle) from QR: Exp(Log(R)) = R.
  for (int i = 0; i < 20; ++i) {
    auto qr = torch::linalg::qr(torch::randn({3, 3}, torch::kDouble), "reduced");
    torch::Tensor r = std::get<0>(qr);
    if (torch::linalg::det(r).item<double>() < 0) r = -r;
    EXPECT_LT((So3Exp(So3Log(r)) - r).abs().max().item<double>(), 1e-9);
  }
}

TEST_F(Se3Test, JacobianOfLogOfExpIsTheIdentity) {
  // Log(Exp(xi)) = xi below pi, so its Jacobian is I: checks Log's gradients in every branch
  // (series at 0, closed form, near pi) are finite and exact.
  const torch::Tensor xi = TestTwists(torch::kDouble);
  for (int64_t i = 0; i < xi.size(0); ++i) {
    const torch::Tensor x = xi[i].clone().requires_grad_(true);
    const torch::Tensor y = Se3Log(Se3Exp(x));
    torch::Tensor jac = torch::zeros({6, 6}, torch::kDouble);
    for (int64_t r = 0; r < 6; ++r) jac[r] = torch::autograd::grad({y[r]}, {x}, {}, true)[0];
    const double angle = xi[i].slice(0, 3, 6).norm().item<double>();
    const double tol = angle < 3.0 ? 1e-8 : 1e-2;
    EXPECT_LT((jac - torch::eye(6, torch::kDouble)).abs().max().item<double>(), tol) << "angle " << angle;
  }
}

TEST_F(Se3Test, ExpOfPiRotationAndItsLog) {
  // Exactly pi about z: R = diag(-1, -1, 1); the antisymmetric part is zero.
  const torch::Tensor r = torch::diag(torch::tensor({-1.0, -1.0, 1.0}, torch::kDouble));
  const torch::Tensor omega = So3Log(r);
  EXPECT_NEAR(omega.norm().item<double>(), M_PI, 1e-12);
  EXPECT_NEAR(std::abs(omega[2].item<double>()), M_PI, 1e-12);
  EXPECT_LT((So3Exp(omega) - r).abs().max().item<double>(), 1e-12);
}

TEST_F(Se3Test, JacobianOfLeftUpdateAtZeroMatchesFiniteDifferencesAndGenerators) {
  const torch::Tensor t = Se3Exp(torch::tensor({0.3, -0.2, 0.5, 0.4, -0.7, 0.2}, torch::kDouble));
  const auto f = [&](const torch::Tensor& delta) { return Se3Update(delta, t).slice(0, 0, 3).reshape(-1); };
  // Autograd Jacobian [12, 6] at delta = 0 (the Taylor branch of Exp).
  const torch::Tensor delta = torch::zeros({6}, torch::kDouble).requires_grad_(true);
  const torch::Tensor y = f(delta);
  torch::Tensor jac = torch::zeros({12, 6}, torch::kDouble);
  for (int64_t i = 0; i < 12; ++i) {
    const auto g = torch::autograd::grad({y[i]}, {delta}, {}, /*retain_graph=*/true);
    jac[i] = g[0];
  }
  ASSERT_TRUE(torch::isfinite(jac).all().item<bool>());
  // Central finite differences.
  const double eps = 1e-6;
  torch::Tensor fd = torch::zeros({12, 6}, torch::kDouble);
  for (int64_t j = 0; j < 6; ++j) {
    torch::Tensor e = torch::zeros({6}, torch::kDouble);
    e[j] = eps;
    fd.select(1, j) = (f(e) - f(-e)) / (2 * eps);
  }
  EXPECT_LT((jac - fd).abs().max().item<double>(), 1e-8);
  // Analytic: d/d delta_j (Exp(delta) T) = G_j T, G_j the se(3) generator (rho first).
  for (int64_t j = 0; j < 6; ++j) {
    torch::Tensor g = torch::zeros({4, 4}, torch::kDouble);
    if (j < 3) {
      g[j][3] = 1.0;
    } else {
      torch::Tensor w = torch::zeros({3}, torch::kDouble);
      w[j - 3] = 1.0;
      g.slice(0, 0, 3).slice(1, 0, 3) = So3Hat(w);
    }
    const torch::Tensor expected = torch::matmul(g, t).slice(0, 0, 3).reshape(-1);
    EXPECT_LT((jac.select(1, j) - expected).abs().max().item<double>(), 1e-10) << j;
  }
}

TEST_F(Se3Test, ComposeInverseApplyAndGeodesicAngleAgree) {
  const torch::Tensor a_from_b = Se3Exp(torch::randn({5, 6}, torch::kDouble));
  const torch::Tensor b_from_c = Se3Exp(torch::randn({5, 6}, torch::kDouble));
  const torch::Tensor eye = torch::eye(4, torch::kDouble).expand({5, 4, 4});
  EXPECT_LT((Se3Compose(a_from_b, Se3Inverse(a_from_b)) - eye).abs().max().item<double>(), 1e-12);
  const torch::Tensor x_in_c = torch::randn({5, 7, 3}, torch::kDouble);
  const torch::Tensor direct = Se3Apply(a_from_b, Se3Apply(b_from_c, x_in_c));
  const torch::Tensor composed = Se3Apply(Se3Compose(a_from_b, b_from_c), x_in_c);
  EXPECT_LT((direct - composed).abs().max().item<double>(), 1e-12);
  // Relative transform of two cameras posed as cam_from_world.
  const torch::Tensor& cam1_from_world = a_from_b;
  const torch::Tensor& cam2_from_world = b_from_c;
  const torch::Tensor cam1_from_cam2 = RelativeTransform(cam1_from_world, cam2_from_world);
  const torch::Tensor x_in_world = torch::randn({5, 4, 3}, torch::kDouble);
  EXPECT_LT((Se3Apply(cam1_from_cam2, Se3Apply(cam2_from_world, x_in_world)) - Se3Apply(cam1_from_world, x_in_world))
                .abs()
                .max()
                .item<double>(),
            1e-12);
  // The geodesic angle between R and Exp(w) R is |w| (w below pi).
  const torch::Tensor w =
      torch::tensor({{0.0, 0.0, 0.0}, {1e-4, 0.0, 0.0}, {0.3, -0.2, 0.1}, {0.0, 3.0, 0.0}}, torch::kDouble);
  const torch::Tensor r = So3Exp(torch::randn({4, 3}, torch::kDouble));
  const torch::Tensor angle = So3GeodesicAngle(r, torch::matmul(So3Exp(w), r));
  EXPECT_LT((angle - w.norm(2, 1)).abs().max().item<double>(), 1e-10);
}

TEST_F(Se3Test, RejectsWrongShapes) {
  EXPECT_THROW(Se3Exp(torch::zeros({3, 5})), c10::Error);
  EXPECT_THROW(Se3Log(torch::zeros({3, 3})), c10::Error);
  EXPECT_THROW(Se3Apply(torch::eye(4), torch::zeros({5, 2})), c10::Error);
}

}  // namespace
}  // namespace nerfreg
