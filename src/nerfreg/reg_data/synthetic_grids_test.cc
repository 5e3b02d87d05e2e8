#include "nerfreg/reg_data/synthetic_grids.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "nerfreg/registration/scale_normalization.h"
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

double ScaleOf(const Eigen::Matrix4d& m) { return std::cbrt(m.topLeftCorner<3, 3>().determinant()); }

double MaskedRadius(const RegGrid& g) {
  const torch::Tensor xyz = g.MaskedXyz().to(torch::kDouble).contiguous();  // [M, 3]
  const Eigen::Map<const Eigen::Matrix3Xd> points(xyz.data_ptr<double>(), 3, xyz.size(0));
  return OccupiedRadius(points);
}

// --scale-augment: each block is shown as reg register --scale free shows it (its seen surface at
// RMS radius kNormalizedRadius), whatever relative scale was drawn before that normalisation, and
// the truth carries the scale between the two normalised frames.
TEST(SyntheticGrids, ScaleAugmentedBlocksAreNormalisedAndTheTruthKeepsTheirScale) {
  torch::set_num_threads(2);
  TriangleMesh mesh = ProceduralObject(4);
  NormalizeMesh(&mesh);
  SyntheticPairOptions plain = Small(), augmented = Small(), tiny = Small();
  plain.blocks = augmented.blocks = tiny.blocks = 4;
  augmented.max_relative_scale = 2;
  tiny.max_relative_scale = 1.001;
  const GridPair p = SyntheticGridPair(mesh, plain, 3), a = SyntheticGridPair(mesh, augmented, 3),
                 t = SyntheticGridPair(mesh, tiny, 3);
  EXPECT_NEAR(ScaleOf(p.target_from_source), 1.0, 1e-9);
  EXPECT_EQ(p.source_normalization, 1.0);
  for (const GridPair* g : {&a, &t}) {
    // Voxel centres of the masked cells: within a cell of the seen points the radius was taken on.
    EXPECT_NEAR(MaskedRadius(g->source), kNormalizedRadius, 0.12);
    EXPECT_NEAR(MaskedRadius(g->target), kNormalizedRadius, 0.12);
    EXPECT_NEAR(ScaleOf(g->target_from_source), g->target_normalization / g->source_normalization, 1e-6);
    EXPECT_GT(g->overlap, 0.5);
    Eigen::Matrix4d rigid = g->target_from_source;
    rigid.topLeftCorner<3, 3>() /= ScaleOf(rigid);
    rigid.topLeftCorner<3, 3>() *= 1.3;  // the truth's rotation at a wrong scale
    EXPECT_LT(GridOverlap(g->source, g->target, rigid), g->overlap - 0.2);
  }
  // The relative scale drawn before the normalisation is normalised away: the two pairs differ in
  // the relative scale drawn (up to 2 against up to 1.001) and show the same grids.
  EXPECT_NEAR(a.source_normalization, t.source_normalization, 1e-6);
  EXPECT_LT((a.source.xyz - t.source.xyz).abs().max().item<double>(), 1e-4);
  EXPECT_LE((a.target.mask != t.target.mask).sum().item<std::int64_t>(), 2);
  // The same object at 0.6 of the size: the plain pair's blocks shrink with it (the mesh unit; not
  // exactly 0.6: the orbit keeps its distance, so the views see a little more of the object), the
  // augmented pair's do not.
  TriangleMesh small = mesh;
  for (auto& v : small.vertices) v *= 0.6f;
  const GridPair ps = SyntheticGridPair(small, plain, 3), as = SyntheticGridPair(small, augmented, 3);
  EXPECT_LT(MaskedRadius(ps.source) / MaskedRadius(p.source), 0.8);
  EXPECT_NEAR(MaskedRadius(as.source), kNormalizedRadius, 0.12);
  EXPECT_NEAR(as.source_normalization / a.source_normalization, 1 / 0.6, 0.12);
}

}  // namespace
}  // namespace nerfreg
