#include "nerfreg/render/surface_splats.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nerfreg/render/procedural.h"
#include "nerfreg/render/renderer.h"
#include "nerfreg/render/trajectory.h"

namespace nerfreg {
namespace {

// A sphere seen from an orbit: every splat on the sphere, flat along its normal, one per voxel;
// the same splats moved by a Sim(3) land where the Sim(3) puts the surface, with scaled sizes.
TEST(SurfaceSplats, SplatsLieFlatOnTheSeenSurfaceAndFollowAFrame) {
  const TriangleMesh sphere = MakeSphere(1.0f, Eigen::Vector3f(0.8f, 0.3f, 0.2f), 32, 64);
  RayCaster caster(sphere);
  OrbitOptions oo;
  oo.num_views = 12;
  oo.width = oo.height = 48;
  const std::vector<PosedCamera> cams = OrbitTrajectory(oo);
  SurfaceSplatOptions so;
  so.voxel = 0.05;
  SurfaceSplatter splatter(caster, so);
  for (int i = 0; i < static_cast<int>(cams.size()); ++i) {
    const RenderResult r = RenderView(caster, sphere, cams[i].camera, cams[i].cam_from_world, RenderOptions());
    splatter.AddView(i, cams[i].camera, cams[i].cam_from_world, r.rgba);
  }
  const Splats all = splatter.Build({});
  const Splats first = splatter.Build({0});
  ASSERT_GT(all.size(), 500);
  EXPECT_LT(first.size(), all.size() / 2);  // one view sees part of the sphere
  for (std::int64_t i = 0; i < all.size(); ++i) {
    const Eigen::Vector3d p = all.position.col(i).cast<double>();
    EXPECT_NEAR(p.norm(), 1.0, 0.01);  // the faceted sphere is within 1 % of the radius
    // The thin axis (the rotated z) is the normal, outward on a sphere seen from outside.
    const Eigen::Vector4d q = all.rotation.col(i).cast<double>();
    const Eigen::Vector3d z = Eigen::Quaterniond(q(0), q(1), q(2), q(3)).toRotationMatrix().col(2);
    EXPECT_GT(z.dot(p.normalized()), 0.95);
    EXPECT_LT(all.log_scale(2, i), all.log_scale(0, i));
  }
  // At most one splat per 0.05 voxel: fewer than the sphere's area over a voxel face, times a margin.
  EXPECT_LT(all.size(), 4 * M_PI / (0.05 * 0.05) * 2);

  const Sim3d frame_from_world(2.0, Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                               Eigen::Vector3d(0.3, -1, 2));
  const Splats moved = splatter.Build({}, frame_from_world);
  ASSERT_EQ(moved.size(), all.size());
  for (std::int64_t i = 0; i < all.size(); ++i) {
    const Eigen::Vector3d expected = frame_from_world * Eigen::Vector3d(all.position.col(i).cast<double>());
    EXPECT_LT((moved.position.col(i).cast<double>() - expected).norm(), 1e-5);
    EXPECT_NEAR(moved.log_scale(0, i), all.log_scale(0, i) + std::log(2.0), 1e-5);
  }
}

}  // namespace
}  // namespace nerfreg
