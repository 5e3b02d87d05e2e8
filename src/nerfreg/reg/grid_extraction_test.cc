#include "nerfreg/reg/grid_extraction.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/nerf/test_train_options.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg_data/synthetic_grids.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A small block of procedural object 2 trained for 250 iterations on 40 32x32 views (~10 s).
NerfBlock TrainSmallBlock(const ScopedTempDir& dir, TriangleMesh* mesh_out) {
  TriangleMesh mesh = ProceduralObject(2);
  NormalizeMesh(&mesh);
  RenderDatasetOptions r;
  r.views = 40;
  r.width = 32;
  r.test_every = 5;
  r.render.supersample = 1;
  RenderDataset(mesh, r, dir.File("data"));
  const Dataset d = ReadTransformsJson(dir.File("data/transforms.json"));
  TrainNerfBlock(d, TinyNerfTrainOptions(250), dir.File("b.ckpt"), false);
  NerfBlock block = LoadNerfBlock(dir.File("b.ckpt"));
  *mesh_out = mesh;
  return block;
}

// Grid options for that block: D = 32; the block is blurry (its surfaces spread their weight over
// several samples: max alpha T averaged ~0.3 on dense voxels), so the mask threshold is lowered
// (chosen for the max_weight surface field; the default window field keeps more of the surface).
GridExtractionOptions SmallBlockGridOptions() {
  GridExtractionOptions go;
  go.resolution = 32;
  go.surface.max_cameras = 8;
  go.surface_threshold = 0.2;
  return go;
}

// A grid extracted from a trained block lies on the object's true surface: it overlaps the
// ground-truth grid of the same object (ray-cast, same frame) and not a rotated copy of it.
TEST(GridExtraction, TrainedBlockGridMatchesTheTrueSurface) {
  torch::set_num_threads(2);
  ScopedTempDir dir;
  TriangleMesh mesh;
  NerfBlock block = TrainSmallBlock(dir, &mesh);

  GridExtractionOptions go = SmallBlockGridOptions();
  const RegGrid g = ExtractRegGrid(block, go);
  const std::int64_t masked = g.mask.sum().item<std::int64_t>();
  ASSERT_GT(masked, 100);
  // The mask is a subset of the density mask, and surface voxels have S >= 0.5.
  EXPECT_GE(g.MaskedSurface().min().item<float>(), 0.2f);
  EXPECT_GT(g.rgba.select(0, 3).index({g.mask}).min().item<float>(), 0.f);
  go.variant = "df";
  const RegGrid df = ExtractRegGrid(block, go);
  EXPECT_GE(df.mask.sum().item<std::int64_t>(), masked);
  // The accumulated-opacity surface field is ~1 on almost every dense voxel (it counts what is
  // in front of X too), the spec's maximum weight is lower on this blurry block.
  go.surface.mode = "opacity";
  const RegGrid op = ExtractRegGrid(block, go);
  EXPECT_GT(op.surface.index({op.mask}).mean().item<float>(), df.surface.index({df.mask}).mean().item<float>());

  // Ground truth: the same object ray-cast on the same grid in the world frame.
  SyntheticPairOptions so;
  so.resolution = 32;
  so.views = 40;
  so.image_size = 32;
  so.blur = 0;
  so.floaters = 0;
  so.frames.max_rotation_deg = 1e-9;
  so.frames.max_translation = 0;
  const GridPair truth = SyntheticGridPair(mesh, so, 1);
  EXPECT_LT((truth.source.aabb_min - g.aabb_min).norm(), 1e-3);
  const double overlap = GridOverlap(g, truth.source, Eigen::Matrix4d::Identity());
  Eigen::Matrix4d turned = Eigen::Matrix4d::Identity();
  turned.topLeftCorner<3, 3>() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_GT(overlap, 0.7);
  EXPECT_LT(GridOverlap(g, truth.source, turned), overlap - 0.2);
}

// A trained block's own field, seen from a known frame (density_moved(x) = density(moved^-1 x)),
// is registered back by AlignFields from 3 deg and 0.05 units off, from the block's extracted
// surface points: the hash-grid field's finite-difference gradients are good enough.
TEST(GridExtraction, FieldAlignmentRecoversAKnownMoveOfATrainedBlock) {
  torch::set_num_threads(2);
  ScopedTempDir dir;
  TriangleMesh mesh;
  NerfBlock block = TrainSmallBlock(dir, &mesh);
  const RegGrid g = ExtractRegGrid(block, SmallBlockGridOptions());
  const Rigid3d moved_from_block(Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -1, 0.6).normalized())),
                                 Eigen::Vector3d(0.2, 0.1, -0.3));
  const DensityField src = BlockDensityField(block);
  DensityField tgt;
  const Rigid3d block_from_moved = moved_from_block.Inverse();
  tgt.density = [&](const torch::Tensor& x) {
    const Eigen::Matrix3d r = block_from_moved.RotationMatrix();
    const torch::Tensor rt = torch::from_blob(const_cast<double*>(r.data()), {3, 3}, torch::kDouble).to(torch::kFloat);
    const torch::Tensor t = torch::tensor({block_from_moved.translation.x(), block_from_moved.translation.y(),
                                           block_from_moved.translation.z()})
                                .to(torch::kFloat);
    // Column-major r read row-major is R^T: x R^T = (R x^T)^T.
    return src.density(torch::matmul(x, rt) + t);
  };
  tgt.box = Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-4), Eigen::Vector3d::Constant(4));
  const Eigen::Matrix3Xd ps = PointsToEigen(g.MaskedXyz());
  Eigen::Matrix3Xd pt(3, ps.cols());
  for (Eigen::Index i = 0; i < ps.cols(); ++i) pt.col(i) = moved_from_block * Eigen::Vector3d(ps.col(i));
  const Eigen::Quaterniond off(Eigen::AngleAxisd(3.0 * M_PI / 180, Eigen::Vector3d(1, 1, 1).normalized()));
  const Rigid3d start(off * moved_from_block.rotation, moved_from_block.translation + Eigen::Vector3d(0.05, 0, -0.02));
  FieldAlignmentOptions fo;
  fo.sample_spread = g.CellSize();
  const FieldAlignmentResult r = AlignFields(src, tgt, ps, pt, start, fo);
  const double deg = RotationErrorDeg(r.target_from_source.rotation, moved_from_block.rotation);
  std::printf("[field] trained block: %d iterations, cost %.4f -> %.4f, %.2f s; 3 deg -> %.3f deg, translation %.4f\n",
              r.iterations, r.initial_cost, r.final_cost, r.seconds, deg,
              (r.target_from_source.translation - moved_from_block.translation).norm());
  EXPECT_LT(deg, 0.2);
  EXPECT_LT((r.target_from_source.translation - moved_from_block.translation).norm(), 0.01);
  EXPECT_LT(r.final_cost, r.initial_cost);
}

}  // namespace
}  // namespace nerfreg
