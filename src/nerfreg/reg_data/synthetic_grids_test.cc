#include "nerfreg/reg_data/synthetic_grids.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "nerfreg/render/mesh.h"
#include "nerfreg/render/procedural.h"

namespace nerfreg {
namespace {

SyntheticPairOptions Small() {
  SyntheticPairOptions o;
  o.resolution = 32;
  o.views = 60;
  o.image_size = 48;
  return o;
}

TEST(SyntheticGrids, PairOverlapsUnderTheTruePoseOnly) {
  torch::set_num_threads(2);
  TriangleMesh mesh = LoadMesh("/usr/share/assimp/models/OBJ/spider.obj");
  NormalizeMesh(&mesh);
  const GridPair p = SyntheticGridPair(mesh, Small(), 5);
  ASSERT_GT(p.source.mask.sum().item<std::int64_t>(), 200);
  ASSERT_GT(p.target.mask.sum().item<std::int64_t>(), 200);
  // The two blocks see much of the same surface (the DReg-NeRF split overlaps ~85 %).
  EXPECT_GT(p.overlap, 0.5);
  // Wrong poses (the true one turned by 90 degrees about the source's x axis, or shifted by 0.4)
  // overlap far less.
  Eigen::Matrix4d turned = p.target_from_source, shifted = p.target_from_source;
  turned.topLeftCorner<3, 3>() =
      turned.topLeftCorner<3, 3>() * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  shifted(0, 3) += 0.4;
  EXPECT_LT(GridOverlap(p.source, p.target, turned), p.overlap - 0.2);
  EXPECT_LT(GridOverlap(p.source, p.target, shifted), p.overlap - 0.2);
  // The frames are arbitrary: the ground truth is not near identity.
  const double angle = Eigen::AngleAxisd(Eigen::Matrix3d(p.target_from_source.topLeftCorner<3, 3>())).angle();
  EXPECT_GT(angle, 0.05);
}

TEST(SyntheticGrids, DeterministicForASeed) {
  torch::set_num_threads(2);
  TriangleMesh mesh = ProceduralObject(4);
  NormalizeMesh(&mesh);
  const GridPair a = SyntheticGridPair(mesh, Small(), 9), b = SyntheticGridPair(mesh, Small(), 9);
  EXPECT_TRUE(torch::equal(a.source.rgba, b.source.rgba));
  EXPECT_TRUE(torch::equal(a.target.mask, b.target.mask));
  EXPECT_EQ(a.target_from_source, b.target_from_source);
}

}  // namespace
}  // namespace nerfreg
