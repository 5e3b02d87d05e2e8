#include "nerfreg/reg/grid_extraction.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/nerf/trainer.h"
#include "nerfreg/reg/synthetic_grids.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A grid extracted from a trained block lies on the object's true surface: it overlaps the
// ground-truth grid of the same object (ray-cast, same frame) and not a rotated copy of it.
TEST(GridExtraction, TrainedBlockGridMatchesTheTrueSurface) {
  torch::set_num_threads(2);
  ScopedTempDir dir;
  TriangleMesh mesh = ProceduralObject(2);
  NormalizeMesh(&mesh);
  RenderDatasetOptions r;
  r.views = 40;
  r.width = 32;
  r.test_every = 5;
  r.render.supersample = 1;
  RenderDataset(mesh, r, dir.File("data"));
  const Dataset d = ReadTransformsJson(dir.File("data/transforms.json"));
  NerfTrainOptions o = NerfTrainOptions::Preset("fast");
  o.iterations = 250;
  o.field.encoding.log2_table_size = 14;
  o.field.encoding.levels = 8;
  o.field.encoding.per_level_scale = 1.5;
  o.grid.resolution = 32;
  o.target_samples = 1 << 13;
  o.eval_every = 0;
  o.checkpoint_every = 0;
  TrainNerfBlock(d, o, dir.File("b.ckpt"), false);
  NerfBlock block = LoadNerfBlock(dir.File("b.ckpt"));

  GridExtractionOptions go;
  go.resolution = 32;
  go.surface.max_cameras = 8;
  // This 250-iteration 32x32 block is blurry: its surfaces spread their weight over several
  // samples (max alpha T averages ~0.3 on dense voxels), so the mask threshold is lowered.
  go.surface_threshold = 0.2;
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

}  // namespace
}  // namespace nerfreg
