#include "nerfreg/nerf/trainer.h"
#include "nerfreg/nerf/field_queries.h"

#include <gtest/gtest.h>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/nerf/test_train_options.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A tiny orbit dataset of a procedural object (32x32, 40 views, every 5th a test view).
Dataset TinyDataset(const std::string& dir) {
  RenderDatasetOptions r;
  r.views = 40;
  r.width = 32;
  r.test_every = 5;
  r.render.supersample = 1;
  RenderDataset(ProceduralObject(2), r, dir + "/data");
  return ReadTransformsJson(dir + "/data/transforms.json");
}

TEST(NerfTrainer, TrainingRaisesHeldOutPsnr) {
  torch::set_num_threads(2);
  ScopedTempDir dir;
  const Dataset d = TinyDataset(dir.path());
  const NerfTrainOptions tiny = TinyNerfTrainOptions(1);
  NerfBlock untrained = NerfBlock::Create(tiny.field, tiny.grid, tiny.march, 0);
  const double before = EvaluateNerfBlock(untrained, d).psnr;
  const NerfTrainResult r = TrainNerfBlock(d, TinyNerfTrainOptions(300), dir.File("b.ckpt"), false);
  EXPECT_EQ(r.iterations, 300);
  EXPECT_GT(r.psnr_test, before + 6.0) << "before " << before;
  EXPECT_GT(r.psnr_test, 20.0);
  EXPECT_TRUE(FileExists(dir.File("b.ckpt.log.jsonl")));

  // Field queries on the trained block. Occupied points are dense; points on the surface a
  // training camera sees (its rays at their rendered depth) have S ~ 1; the empty corners of the
  // box have S ~ 0.
  NerfBlock block = LoadNerfBlock(dir.File("b.ckpt"));
  const BlockPoints pts = ExtractOccupiedPoints(block, 10.0);
  ASSERT_GT(pts.xyz.size(0), 100);
  EXPECT_GT(pts.sigma.min().item<float>(), 10.f);
  const Frame& cam = d.frames[d.IndicesOfSplit("train")[0]];
  torch::Tensor o, dirs;
  CameraRays(cam.camera, cam.cam_from_world, &o, &dirs);
  const RenderedRays rr = RenderRays(block, o, dirs, torch::ones({3}));
  const auto hit = (rr.opacity > 0.95).nonzero().squeeze(1);
  ASSERT_GT(hit.numel(), 50);
  const auto surface = o.index_select(0, hit) + dirs.index_select(0, hit) * rr.depth.index_select(0, hit).unsqueeze(1);
  SurfaceFieldOptions so;
  so.max_cameras = 8;
  const auto s_surface = SurfaceField(block, surface, so);
  const auto empty =
      torch::tensor({{1.3f, 1.3f, 1.3f}, {-1.3f, 1.3f, 1.3f}, {1.3f, -1.3f, 1.3f}, {-1.3f, -1.3f, 1.3f}});
  const auto s_empty = SurfaceField(block, empty, so);
  // S = max_i alpha_i T_i is below 1 on this tiny, blurry block (its surfaces spread over several
  // samples): assert the separation between surface and empty space.
  EXPECT_GT(s_surface.mean().item<float>(), 0.25f);
  EXPECT_LT(s_empty.max().item<float>(), 0.05f);

  // Mode window: the ray's weight within a stretch around the point. From the one camera whose
  // rays found the surface, it is high where they end and ~0 a little behind it (the ray has ended;
  // opacity, 1 - T, stays ~1 there), and it does not shrink with the march step as max_weight does.
  SurfaceFieldOptions one = so;
  one.max_cameras = 1;  // the first training camera: `cam`
  SurfaceFieldOptions window = one;
  window.mode = "window";
  window.window = 0.2;
  SurfaceFieldOptions opacity = one;
  opacity.mode = "opacity";
  const auto behind = surface + dirs.index_select(0, hit) * 0.3;
  const float w_surface = SurfaceField(block, surface, window).mean().item<float>();
  EXPECT_GT(w_surface, 0.5f);
  EXPECT_GT(w_surface, SurfaceField(block, surface, one).mean().item<float>() + 0.1f);
  EXPECT_LT(SurfaceField(block, behind, window).mean().item<float>(), 0.1f);
  EXPECT_GT(SurfaceField(block, behind, opacity).mean().item<float>(), 0.9f);
  EXPECT_LT(SurfaceField(block, empty, window).max().item<float>(), 0.05f);
  SurfaceFieldOptions fine = window;
  fine.step_size = 0.25 * block.march.step_size;
  SurfaceFieldOptions fine_max = one;
  fine_max.step_size = fine.step_size;
  EXPECT_NEAR(SurfaceField(block, surface, fine).mean().item<float>(), w_surface, 0.05f);
  EXPECT_LT(SurfaceField(block, surface, fine_max).mean().item<float>(),
            SurfaceField(block, surface, one).mean().item<float>());
  window.window = 0;
  EXPECT_THROW(window.Check(), std::invalid_argument);
}

TEST(NerfTrainer, CheckpointRoundTripAndExactResume) {
  torch::set_num_threads(2);
  ScopedTempDir dir;
  const Dataset d = TinyDataset(dir.path());
  // 60 steps straight vs 30 steps, then resumed to 60 from the checkpoint.
  TrainNerfBlock(d, TinyNerfTrainOptions(60), dir.File("straight.ckpt"), false);
  NerfTrainOptions first_half = TinyNerfTrainOptions(60);
  first_half.stop_after = 30;
  TrainNerfBlock(d, first_half, dir.File("resumed.ckpt"), false);
  EXPECT_EQ(LoadNerfBlock(dir.File("resumed.ckpt")).step, 30);
  TrainNerfBlock(d, TinyNerfTrainOptions(60), dir.File("resumed.ckpt"), true);
  NerfBlock a = LoadNerfBlock(dir.File("straight.ckpt")), b = LoadNerfBlock(dir.File("resumed.ckpt"));
  EXPECT_EQ(a.step, 60);
  EXPECT_EQ(b.step, 60);
  EXPECT_LT((a.field->table - b.field->table).abs().max().item<float>(), 1e-6);
  // Save -> load -> identical renders; the cameras travel with the checkpoint.
  ASSERT_EQ(b.cameras.frames.size(), d.frames.size());
  const Frame& f = d.frames[3];
  const Image i1 = RenderImage(a, f.camera, f.cam_from_world);
  SaveNerfBlock(a, dir.File("copy.ckpt"));
  NerfBlock c = LoadNerfBlock(dir.File("copy.ckpt"));
  const Image i2 = RenderImage(c, f.camera, f.cam_from_world);
  for (size_t k = 0; k < i1.data.size(); ++k) ASSERT_EQ(i1.data[k], i2.data[k]);
}

TEST(NerfTrainer, BadCheckpointsAndDatasetsAreNamedErrors) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("junk.ckpt"), "not a checkpoint");
  EXPECT_THROW(LoadNerfBlock(dir.File("junk.ckpt")), InputError);
  EXPECT_THROW(LoadNerfBlock(dir.File("missing.ckpt")), InputError);
  const NerfTrainOptions tiny = TinyNerfTrainOptions(1);
  NerfBlock b = NerfBlock::Create(tiny.field, tiny.grid, tiny.march, 0);
  SaveNerfBlock(b, dir.File("ok.ckpt"));
  const std::string bytes = ReadFileToString(dir.File("ok.ckpt"));
  WriteFileAtomic(dir.File("truncated.ckpt"), bytes.substr(0, bytes.size() / 2));
  try {
    LoadNerfBlock(dir.File("truncated.ckpt"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated.ckpt"), std::string::npos);
  }
  Dataset no_train;
  Frame f;
  f.name = "a.png";
  f.split = "test";
  no_train.frames.push_back(f);
  EXPECT_THROW(TrainNerfBlock(no_train, TinyNerfTrainOptions(1), dir.File("x.ckpt"), false), InputError);
}

TEST(NerfTrainer, SparseTableAdamResumesExactly) {
  torch::set_num_threads(2);
  ScopedTempDir dir;
  const Dataset d = TinyDataset(dir.path());
  NerfTrainOptions o = TinyNerfTrainOptions(24);
  o.sparse_table_adam = true;
  TrainNerfBlock(d, o, dir.File("straight.ckpt"), false);
  NerfTrainOptions half = o;
  half.stop_after = 12;
  TrainNerfBlock(d, half, dir.File("resumed.ckpt"), false);
  TrainNerfBlock(d, TinyNerfTrainOptions(24), dir.File("resumed.ckpt"), true);  // the checkpoint's optimizer is kept
  NerfBlock a = LoadNerfBlock(dir.File("straight.ckpt")), b = LoadNerfBlock(dir.File("resumed.ckpt"));
  EXPECT_EQ(b.step, 24);
  EXPECT_TRUE(b.train_options.value("sparse_table_adam", false));
  EXPECT_LT((a.field->table - b.field->table).abs().max().item<float>(), 1e-6);
}

}  // namespace
}  // namespace nerfreg
