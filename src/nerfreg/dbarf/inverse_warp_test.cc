#include "nerfreg/dbarf/inverse_warp.h"

#include <gtest/gtest.h>

#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/test_scene.h"

namespace nerfreg {
namespace {

using testing_scene::PlaneScene;

class InverseWarpTest : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(1);
    torch::manual_seed(5);
  }
};

TEST_F(InverseWarpTest, ScaleIntrinsicsScalesFocalAndPrincipalPointOnACopy) {
  const torch::Tensor k = torch::tensor({{100.0f, 0.0f, 64.0f}, {0.0f, 90.0f, 48.0f}, {0.0f, 0.0f, 1.0f}});
  const torch::Tensor k8 = ScaleIntrinsics(k, 1.0 / 8.0);
  EXPECT_FLOAT_EQ(k8[0][0].item<float>(), 12.5f);
  EXPECT_FLOAT_EQ(k8[1][1].item<float>(), 11.25f);
  EXPECT_FLOAT_EQ(k8[0][2].item<float>(), 8.0f);
  EXPECT_FLOAT_EQ(k8[1][2].item<float>(), 6.0f);
  EXPECT_FLOAT_EQ(k8[2][2].item<float>(), 1.0f);
  EXPECT_FLOAT_EQ(k[0][0].item<float>(), 100.0f);  // input untouched
}

TEST_F(InverseWarpTest, ResizeIntrinsicsPerAxisAndAreaDownsampleAveragesBlocks) {
  const torch::Tensor k = torch::tensor({{100.0f, 0.0f, 64.0f}, {0.0f, 90.0f, 48.0f}, {0.0f, 0.0f, 1.0f}});
  for (const torch::Tensor& ks : {k, k.expand({2, 3, 3})}) {  // one camera or a batch
    const torch::Tensor r = ResizeIntrinsics(ks, 0.5, 0.25).view({-1, 3, 3})[0];
    EXPECT_FLOAT_EQ(r[0][0].item<float>(), 50.0f);
    EXPECT_FLOAT_EQ(r[0][2].item<float>(), 32.0f);
    EXPECT_FLOAT_EQ(r[1][1].item<float>(), 22.5f);
    EXPECT_FLOAT_EQ(r[1][2].item<float>(), 12.0f);
    EXPECT_FLOAT_EQ(r[2][2].item<float>(), 1.0f);
  }
  const torch::Tensor x = torch::arange(16, torch::kFloat).view({1, 1, 4, 4});
  const torch::Tensor d = AreaDownsample(x, 2, 2);
  EXPECT_TRUE(torch::allclose(d, torch::tensor({{2.5f, 4.5f}, {10.5f, 12.5f}}).view({1, 1, 2, 2})));
  EXPECT_TRUE(AreaDownsample(x, 4, 4).is_same(x));
}

TEST_F(InverseWarpTest, IdentityPoseReproducesTheSourceExactly) {
  const torch::Tensor source = torch::rand({2, 3, 12, 16});
  const torch::Tensor k = torch::tensor({{14.0f, 0.0f, 8.0f}, {0.0f, 14.0f, 6.0f}, {0.0f, 0.0f, 1.0f}});
  const torch::Tensor inv_depth = torch::rand({1, 1, 12, 16}) + 0.2;
  const auto res = InverseWarp(source, inv_depth, torch::eye(4).expand({2, 4, 4}), k);
  EXPECT_LT((res.warped - source).abs().max().item<double>(), 1e-5);
  EXPECT_EQ(res.valid.min().item<float>(), 1.0f);
}

TEST_F(InverseWarpTest, TranslationOnAPlaneShiftsByWholePixels) {
  // Plane at depth 2, fx = 40, tx = 0.1: every pixel moves by fx tx / z = 2 columns.
  const int64_t h = 10, w = 14;
  const torch::Tensor source = torch::rand({1, 3, h, w});
  const torch::Tensor k = torch::tensor({{40.0f, 0.0f, 7.0f}, {0.0f, 40.0f, 5.0f}, {0.0f, 0.0f, 1.0f}});
  torch::Tensor src_from_tgt = torch::eye(4).unsqueeze(0).clone();
  src_from_tgt[0][0][3] = 0.1f;
  const auto res = InverseWarp(source, torch::full({1, 1, h, w}, 0.5f), src_from_tgt, k);
  // x_src = x_tgt + 0.1 -> u_src = u_tgt + 2: warped column c is source column c + 2.
  const torch::Tensor inner = res.warped.slice(3, 0, w - 2);
  EXPECT_LT((inner - source.slice(3, 2, w)).abs().max().item<double>(), 1e-5);
  EXPECT_EQ(res.valid.slice(3, 0, w - 2).min().item<float>(), 1.0f);
  // Columns w-2 and w-1 land at u = w + 0.5 and w + 1.5: outside the source.
  EXPECT_EQ(res.valid.slice(3, w - 2, w).max().item<float>(), 0.0f);
  EXPECT_EQ(res.valid.slice(3, w - 1, w).max().item<float>(), 0.0f);
}

TEST_F(InverseWarpTest, WarpedSourceEqualsTargetOnAnAnalyticPlane) {
  for (const PlaneScene& scene : {PlaneScene::FrontoParallel(2.0), PlaneScene::Tilted(2.0), PlaneScene::Ridge(2.0)}) {
    const torch::Tensor src_from_tgt = testing_scene::SourcePoses(3);
    std::vector<torch::Tensor> sources;
    for (int64_t i = 0; i < 3; ++i) sources.push_back(scene.Render(src_from_tgt[i]));
    const torch::Tensor target = scene.Render(torch::eye(4));
    const auto res = InverseWarp(torch::cat(sources, 0), scene.TargetInverseDepth(), src_from_tgt, scene.intrinsics);
    const torch::Tensor valid = res.valid;
    EXPECT_GT(valid.mean().item<double>(), 0.6);
    // Exact up to bilinear interpolation of a smooth texture.
    const torch::Tensor err = (res.warped - target).abs() * valid;
    EXPECT_LT(err.max().item<double>(), 0.02);
    EXPECT_LT((err.sum() / (3 * valid.sum())).item<double>(), 3e-3);
    // Sanity: the unwarped sources differ from the target by far more.
    EXPECT_GT((torch::cat(sources, 0) - target).abs().mean().item<double>(), 0.03);
  }
}

TEST_F(InverseWarpTest, SourcesWithTheirOwnIntrinsicsAndSize) {
  const PlaneScene target_scene = PlaneScene::Tilted(2.0);
  PlaneScene source_scene = PlaneScene::Tilted(2.0, 40, 56);  // another camera: size, focal, centre
  source_scene.intrinsics = torch::tensor({{44.0f, 0.0f, 27.0f}, {0.0f, 46.0f, 21.0f}, {0.0f, 0.0f, 1.0f}});
  const torch::Tensor src_from_tgt = testing_scene::SourcePoses(2);
  const torch::Tensor sources =
      torch::cat({source_scene.Render(src_from_tgt[0]), source_scene.Render(src_from_tgt[1])}, 0);
  const torch::Tensor target = target_scene.Render(torch::eye(4));
  const auto res = InverseWarp(sources, target_scene.TargetInverseDepth(), src_from_tgt, target_scene.intrinsics,
                               source_scene.intrinsics);
  EXPECT_EQ(res.warped.sizes(), (std::vector<int64_t>{2, 3, 48, 64}));
  EXPECT_GT(res.valid.mean().item<double>(), 0.4);
  const torch::Tensor err = (res.warped - target).abs() * res.valid;
  EXPECT_LT((err.sum() / (3 * res.valid.sum())).item<double>(), 3e-3);
  // With the target's intrinsics assumed for the sources the warp is wrong.
  const auto wrong = InverseWarp(sources, target_scene.TargetInverseDepth(), src_from_tgt, target_scene.intrinsics);
  const torch::Tensor err_wrong = (wrong.warped - target).abs() * wrong.valid;
  EXPECT_GT((err_wrong.sum() / (3 * wrong.valid.sum())).item<double>(), 0.02);
}

TEST_F(InverseWarpTest, PointsBehindTheSourceAreInvalid) {
  const torch::Tensor k = torch::tensor({{10.0f, 0.0f, 4.0f}, {0.0f, 10.0f, 4.0f}, {0.0f, 0.0f, 1.0f}});
  torch::Tensor src_from_tgt = torch::eye(4).unsqueeze(0).clone();
  src_from_tgt[0][2][3] = -5.0f;  // source 5 units in front of the plane at depth 1
  const auto res = InverseWarp(torch::rand({1, 1, 8, 8}), torch::ones({1, 1, 8, 8}), src_from_tgt, k);
  EXPECT_EQ(res.valid.max().item<float>(), 0.0f);
  EXPECT_TRUE(torch::isfinite(res.warped).all().item<bool>());
}

}  // namespace
}  // namespace nerfreg
