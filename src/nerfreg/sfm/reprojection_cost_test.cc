#include "nerfreg/sfm/reprojection_cost.h"

#include <gtest/gtest.h>

#include <array>
#include <random>
#include <vector>

namespace nerfreg {
namespace {

// Residuals and Jacobians of one cost for the given blocks; jacobians[b] is row-major 2 x size.
struct Evaluation {
  std::array<double, 2> residual{};
  std::vector<std::vector<double>> jacobians;
};

Evaluation Evaluate(const ceres::CostFunction& cost, const std::vector<double*>& blocks) {
  Evaluation e;
  std::vector<double*> jacobians;
  for (int size : cost.parameter_block_sizes()) {
    e.jacobians.emplace_back(2 * size, 0.0);
    jacobians.push_back(e.jacobians.back().data());
  }
  EXPECT_TRUE(cost.Evaluate(blocks.data(), e.residual.data(), jacobians.data()));
  return e;
}

// The written-out derivatives against automatic differentiation of the same residual: rotations
// from none (the first-order branch) to 3 rad, every distortion coefficient, the intrinsics held
// and refined, and a point behind the camera (projected at the clamped depth).
TEST(ReprojectionCost, AnalyticJacobiansEqualAutomaticDerivatives) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Camera camera;
  camera.width = 640, camera.height = 480;
  camera.fx = 510, camera.fy = 505, camera.cx = 322, camera.cy = 239;
  camera.k1 = -0.21, camera.k2 = 0.07, camera.p1 = 0.0013, camera.p2 = -0.0021, camera.k3 = 0.011, camera.k4 = -0.004;
  const Eigen::Vector2d uv(300.5, 250.25);
  int checked = 0;
  for (const double angle : {0.0, 1e-9, 1e-4, 0.3, 1.7, 3.0}) {
    for (int trial = 0; trial < 4; ++trial) {
      const Eigen::Vector3d axis = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).normalized();
      std::array<double, 6> pose{};
      for (int a = 0; a < 3; ++a) pose[a] = angle * axis(a), pose[3 + a] = 0.3 * uniform(rng);
      // A point 2-4 units in front of the camera (the last trial: behind it).
      Eigen::Matrix3d rotation;
      ceres::AngleAxisToRotationMatrix(pose.data(), ceres::ColumnMajorAdapter3x3(rotation.data()));
      const Eigen::Vector3d in_cam(0.4 * uniform(rng), 0.4 * uniform(rng), trial == 3 ? -1.0 : 3 + uniform(rng));
      Eigen::Vector3d point = rotation.transpose() * (in_cam - Eigen::Vector3d(pose[3], pose[4], pose[5]));
      std::array<double, 3> intrinsics{camera.fx, camera.k1, camera.k2};
      for (const bool refine : {false, true}) {
        SCOPED_TRACE(testing::Message() << "angle " << angle << " trial " << trial << " refine " << refine);
        const ReprojectionCost analytic(uv, camera, refine);
        std::vector<double*> blocks{pose.data(), point.data()};
        if (refine) blocks.push_back(intrinsics.data());
        const Evaluation a = Evaluate(analytic, blocks);
        const Evaluation reference = refine ? Evaluate(ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 6, 3, 3>(
                                                           new ReprojectionResidual(uv, camera)),
                                                       blocks)
                                            : Evaluate(ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 6, 3>(
                                                           new ReprojectionResidual(uv, camera)),
                                                       blocks);
        for (int r = 0; r < 2; ++r)
          EXPECT_NEAR(a.residual[r], reference.residual[r], 1e-9 * (1 + std::abs(reference.residual[r])));
        ASSERT_EQ(a.jacobians.size(), reference.jacobians.size());
        for (size_t b = 0; b < a.jacobians.size(); ++b)
          for (size_t k = 0; k < a.jacobians[b].size(); ++k)
            EXPECT_NEAR(a.jacobians[b][k], reference.jacobians[b][k], 1e-7 * (1 + std::abs(reference.jacobians[b][k])))
                << "block " << b << " entry " << k;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 48);
}

}  // namespace
}  // namespace nerfreg
