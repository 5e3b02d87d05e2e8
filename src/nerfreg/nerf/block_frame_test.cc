// A block moved into another frame (NerfBlock::world_from_field, MoveNerfBlock: `reg apply`)
// answers every query as the original block would at the moved point, without resampling.
#include <gtest/gtest.h>

#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/nerf/mesh_export.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/nerf/splat_export.h"
#include "nerfreg/nerf/test_train_options.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// An untrained block (random field, every grid cell occupied) and one camera looking at it.
NerfBlock TestBlock() {
  const NerfTrainOptions o = TinyNerfTrainOptions(1);
  NerfBlock b = NerfBlock::Create(o.field, o.grid, o.march, 5);
  const std::int64_t g = o.grid.resolution;
  b.grid->SetState(torch::ones({g, g, g}), torch::ones({g, g, g}, torch::kBool));
  Frame f;
  f.name = f.file_path = "r_000.png";
  f.camera = Camera::Pinhole(16, 12, 20, 20, 8, 6);
  f.cam_from_world = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1, 0, 3));
  f.near = 1;
  f.far = 5;
  b.cameras.frames.push_back(f);
  return b;
}

const Sim3d kNewFromOld(1.7, Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -1, 0.5).normalized())),
                        Eigen::Vector3d(0.4, -2.0, 1.5));

// points [N, 3] -> t * points [N, 3].
torch::Tensor Move(const Sim3d& t, const torch::Tensor& points) {
  const torch::Tensor p = points.to(torch::kDouble).contiguous();
  Eigen::Matrix3Xf q(3, p.size(0));
  const double* d = p.data_ptr<double>();
  for (Eigen::Index i = 0; i < q.cols(); ++i)
    q.col(i) = (t * Eigen::Vector3d(d[3 * i], d[3 * i + 1], d[3 * i + 2])).cast<float>();
  return torch::from_blob(q.data(), {q.cols(), 3}, torch::kFloat32).clone();
}

TEST(BlockFrame, MovedBlockAnswersAtMovedPointsWithDensityPerItsOwnLength) {
  NerfBlock old_block = TestBlock(), moved = TestBlock();
  MoveNerfBlock(&moved, kNewFromOld);
  ASSERT_TRUE(moved.Moved());
  const torch::Tensor p = torch::rand({500, 3}) * 2.4 - 1.2;
  const torch::Tensor sigma_old = BlockDensity(old_block, p), sigma_new = BlockDensity(moved, Move(kNewFromOld, p));
  EXPECT_TRUE(torch::allclose(sigma_new * kNewFromOld.scale, sigma_old, 1e-3, 1e-5));
  // The camera moved with the block sees the same image (the march happens in the field's frame).
  const Frame& f_old = old_block.cameras.frames[0];
  const Frame& f_new = moved.cameras.frames[0];
  EXPECT_NEAR(f_new.near, f_old.near * kNewFromOld.scale, 1e-12);
  const Image a = RenderImage(old_block, f_old.camera, f_old.cam_from_world);
  const Image b = RenderImage(moved, f_new.camera, f_new.cam_from_world);
  double max_diff = 0, spread = 0;
  for (size_t k = 0; k < a.data.size(); ++k) {
    max_diff = std::max<double>(max_diff, std::abs(a.data[k] - b.data[k]));
    spread = std::max<double>(spread, std::abs(a.data[k] - a.data[0]));
  }
  EXPECT_LT(max_diff, 2e-3);
  EXPECT_GT(spread, 1e-3);  // the image is not a flat background
  // Occupied points (same jitter) move with the block; splats sit on them, sized by its scale.
  const BlockPoints po = ExtractOccupiedPoints(old_block, 0.0, 3), pn = ExtractOccupiedPoints(moved, 0.0, 3);
  ASSERT_EQ(po.xyz.size(0), pn.xyz.size(0));
  EXPECT_LT((Move(kNewFromOld, po.xyz) - pn.xyz).abs().max().item<double>(), 1e-4);
  const Splats so = BlockToSplats(old_block, {0.0, 3}), sn = BlockToSplats(moved, {0.0, 3});
  ASSERT_EQ(so.size(), po.xyz.size(0));
  EXPECT_NEAR(sn.log_scale(0, 0) - so.log_scale(0, 0), std::log(kNewFromOld.scale), 1e-5);
  EXPECT_NEAR(std::exp(so.log_scale(0, 0)), 0.5 * 3.0 / 32, 1e-6);  // half a cell of the [-1.5, 1.5] box at 32^3
}

TEST(BlockFrame, FrameSurvivesTheCheckpointAndTheInverseRestoresTheIdentity) {
  ScopedTempDir dir;
  NerfBlock b = TestBlock();
  MoveNerfBlock(&b, kNewFromOld);
  SaveNerfBlock(b, dir.File("moved.ckpt"));
  NerfBlock loaded = LoadNerfBlock(dir.File("moved.ckpt"));
  EXPECT_LT((loaded.world_from_field.ToMatrix() - kNewFromOld.ToMatrix()).norm(), 1e-12);
  MoveNerfBlock(&loaded, kNewFromOld.Inverse());
  EXPECT_FALSE(loaded.Moved());
  const NerfBlock original = TestBlock();
  const Rigid3d& a = loaded.cameras.frames[0].cam_from_world;
  const Rigid3d& o = original.cameras.frames[0].cam_from_world;
  EXPECT_LT((a.ToMatrix() - o.ToMatrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(loaded.cameras.frames[0].far, 5.0, 1e-12);
  SaveNerfBlock(original, dir.File("plain.ckpt"));
  EXPECT_FALSE(LoadNerfBlock(dir.File("plain.ckpt")).Moved());
}

}  // namespace
}  // namespace nerfreg

namespace nerfreg {
namespace {

// The shell of a block's occupied points (what a block is matched with against splats): a ball of
// occupied cells gives back its boundary, one cell thick, and none of its inside.
TEST(OccupiedPoints, ShellIsTheBoundaryOfTheDenseCells) {
  NerfBlock b = TestBlock();
  const std::int64_t g = b.grid->resolution();
  const torch::Tensor centres = b.grid->CellCenters();  // [G^3, 3]
  const double cell = (b.field_options.aabb_max[0] - b.field_options.aabb_min[0]) / g;
  const double radius = 0.3 * (b.field_options.aabb_max[0] - b.field_options.aabb_min[0]);
  const torch::Tensor centre = torch::tensor({0.5 * (b.field_options.aabb_max[0] + b.field_options.aabb_min[0]),
                                              0.5 * (b.field_options.aabb_max[1] + b.field_options.aabb_min[1]),
                                              0.5 * (b.field_options.aabb_max[2] + b.field_options.aabb_min[2])},
                                             torch::kFloat32);
  const torch::Tensor ball = ((centres - centre).norm(2, 1) < radius).reshape({g, g, g});
  b.grid->SetState(torch::ones({g, g, g}), ball);
  // min_density -1: every occupied cell is dense, whatever the untrained field says.
  const BlockPoints solid = ExtractOccupiedPoints(b, -1.0, 3), shell = ExtractOccupiedPoints(b, -1.0, 3, true);
  EXPECT_EQ(solid.xyz.size(0), ball.sum().item<std::int64_t>());
  ASSERT_GT(shell.xyz.size(0), 0);
  EXPECT_LT(shell.xyz.size(0), solid.xyz.size(0) / 2);
  // Jittered within their cells: every shell point within ~2 cells of the sphere, none deep inside.
  const torch::Tensor r = (shell.xyz - centre).norm(2, 1);
  EXPECT_GT(r.min().item<double>(), radius - 2.5 * cell);
  EXPECT_LT(r.max().item<double>(), radius + cell);
  // Every cell on the sphere is in the shell: it is closed (about the sphere's area in cells).
  const double area_cells = 4 * M_PI * radius * radius / (cell * cell);
  EXPECT_GT(shell.xyz.size(0), 0.8 * area_cells);
}

}  // namespace
}  // namespace nerfreg
