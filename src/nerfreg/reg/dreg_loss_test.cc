#include "nerfreg/reg/dreg_loss.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "nerfreg/reg/test_grids.h"

namespace nerfreg {
namespace {

using torch::indexing::None;
using torch::indexing::Slice;

torch::Tensor Apply(const torch::Tensor& m, const torch::Tensor& x) {
  return torch::matmul(x, m.slice(0, 0, 3).slice(1, 0, 3).t()) + m.slice(0, 0, 3).select(1, 3);
}

class DregLossTest : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(2);
    torch::manual_seed(5);
    r_ = Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.3, 1.0, -0.2).normalized()).toRotationMatrix();
    t_ = Eigen::Vector3d(0.1, -0.15, 0.05);
    src_ = MakeShapeGrid(32, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1);
    tgt_ = MakeShapeGrid(32, r_, t_, 2);
    gt_ = RigidMatrix(r_, t_);
  }

  // A hand-built DregOutput with `layers` identical layers: keypoints are every 8th masked voxel
  // of each grid; `perfect` predictions put each match at its ground-truth position, give
  // confidence = S (the BCE optimum) and make matched features equal one-hot codes (by nearest GT point);
  // wrong ones scatter the matches, give logits -8 and random features.
  DregOutput Build(bool perfect, int layers = 2) {
    DregOutput out;
    out.src_xyz = src_.xyz.index({src_.mask}).index({Slice(None, None, 8)});
    out.tgt_xyz = tgt_.xyz.index({tgt_.mask}).index({Slice(None, None, 8)});
    out.src_surface = src_.surface.index({src_.mask}).index({Slice(None, None, 8)});
    out.tgt_surface = tgt_.surface.index({tgt_.mask}).index({Slice(None, None, 8)});
    const int64_t ks = out.src_xyz.size(0), kt = out.tgt_xyz.size(0), d = 16;
    const torch::Tensor src_in_tgt = Apply(gt_, out.src_xyz);
    const torch::Tensor tgt_in_src = Apply(torch::inverse(gt_), out.tgt_xyz);
    // Features: a code per target keypoint; each source keypoint takes the code of its nearest
    // target keypoint (in the target frame).
    const torch::Tensor codes = torch::randn({kt, d});
    const torch::Tensor nearest = torch::cdist(src_in_tgt, out.tgt_xyz).argmin(1);
    out.feature_w = (3.0 * torch::eye(d)).requires_grad_(true);
    for (int l = 0; l < layers; ++l) {
      if (perfect) {
        out.src_corr.push_back(src_in_tgt.clone().requires_grad_(true));
        out.tgt_corr.push_back(tgt_in_src.clone().requires_grad_(true));
        out.src_conf_logits.push_back(torch::logit(out.src_surface, 1e-4));
        out.tgt_conf_logits.push_back(torch::logit(out.tgt_surface, 1e-4));
        out.src_features.push_back(codes.index_select(0, nearest));
        out.tgt_features.push_back(codes.clone());
      } else {
        out.src_corr.push_back((torch::rand({ks, 3}) * 2.4 - 1.2).requires_grad_(true));
        out.tgt_corr.push_back((torch::rand({kt, 3}) * 2.4 - 1.2).requires_grad_(true));
        out.src_conf_logits.push_back(torch::full({ks}, -8.0));
        out.tgt_conf_logits.push_back(torch::full({kt}, -8.0));
        out.src_features.push_back(torch::randn({ks, d}));
        out.tgt_features.push_back(torch::randn({kt, d}));
      }
      out.src_conf.push_back(torch::sigmoid(out.src_conf_logits.back()));
      out.tgt_conf.push_back(torch::sigmoid(out.tgt_conf_logits.back()));
      out.rotation.push_back(torch::eye(3));
      out.translation.push_back(torch::zeros({3}));
      out.scale.push_back(torch::ones({}));
      out.pose_valid.push_back(torch::ones({}, torch::kBool));
    }
    return out;
  }

  Eigen::Matrix3d r_;
  Eigen::Vector3d t_;
  RegGrid src_, tgt_;
  torch::Tensor gt_;
};

TEST_F(DregLossTest, BarronLossValues) {
  const torch::Tensor x = torch::tensor({0.0, 0.5, -1.0}, torch::kDouble);
  const torch::Tensor rho = BarronLoss(x, 1.0, 0.5);
  EXPECT_NEAR(rho[0].item<double>(), 0.0, 1e-12);
  EXPECT_NEAR(rho[1].item<double>(), std::sqrt(2.0) - 1.0, 1e-12);
  EXPECT_NEAR(rho[2].item<double>(), std::sqrt(5.0) - 1.0, 1e-12);
  EXPECT_NEAR(BarronLoss(x, 2.0, 0.5)[2].item<double>(), 2.0, 1e-12);            // 0.5 (x / c)^2
  EXPECT_NEAR(BarronLoss(x, 0.0, 0.5)[2].item<double>(), std::log(3.0), 1e-12);  // log(0.5 (x/c)^2 + 1)
  EXPECT_NEAR(BarronLoss(x, 1.999999, 0.5)[2].item<double>(), 2.0, 1e-4);        // continuous at 2
}

TEST_F(DregLossTest, SampleSurfaceReadsVoxelCentresAndIsZeroOutside) {
  const torch::Tensor s = src_.surface;
  const torch::Tensor idx = torch::tensor({{3, 4, 5}, {16, 16, 20}, {10, 22, 9}}, torch::kLong);
  torch::Tensor centres = torch::zeros({3, 3});
  for (int n = 0; n < 3; ++n) {
    for (int a = 0; a < 3; ++a) centres[n][a] = -1.5 + (idx[n][a].item<int64_t>() + 0.5) * src_.CellSize();
  }
  const torch::Tensor got = SampleSurface(src_, centres);
  for (int n = 0; n < 3; ++n) {
    EXPECT_NEAR(got[n].item<float>(), s[idx[n][0]][idx[n][1]][idx[n][2]].item<float>(), 1e-5);
  }
  EXPECT_EQ(SampleSurface(src_, torch::tensor({{2.0f, 0.0f, 0.0f}})).item<float>(), 0.0f);
  // Points on the surface read high, points in empty space zero.
  const torch::Tensor on = src_.xyz.index({src_.surface > 0.9});
  EXPECT_GT(SampleSurface(src_, on).mean().item<float>(), 0.5f);
  EXPECT_LT(SampleSurface(src_, torch::tensor({{1.3f, 1.3f, 1.3f}})).item<float>(), 1e-6f);
}

TEST_F(DregLossTest, PerfectPredictionsScoreLowerOnEveryTerm) {
  const DregLossTerms good = DregLoss(Build(true), src_, tgt_, gt_);
  const DregLossTerms bad = DregLoss(Build(false), src_, tgt_, gt_);
  // Soft labels: the BCE optimum is the labels' entropy, 2 layers x mean H(S).
  const torch::Tensor s = torch::cat({src_.surface.index({src_.mask}).index({Slice(None, None, 8)}),
                                      tgt_.surface.index({tgt_.mask}).index({Slice(None, None, 8)})})
                              .clamp(1e-4, 1 - 1e-4);
  const double entropy = -(s * s.log() + (1 - s) * (1 - s).log()).mean().item<double>();
  EXPECT_NEAR(good.confidence.item<double>(), 2.0 * entropy, 1e-4);
  EXPECT_GT(bad.confidence.item<double>(), 10.0);  // 2 layers x ~8 nats
  EXPECT_LT(good.correspondence.item<double>(), 1e-6);
  EXPECT_GT(bad.correspondence.item<double>(), 1.0);
  EXPECT_LT(good.surface.item<double>(), 0.5 * bad.surface.item<double>());
  EXPECT_LT(good.feature.item<double>(), 0.5 * bad.feature.item<double>());
  EXPECT_LT(good.total.item<double>(), 0.2 * bad.total.item<double>());
  // Only the last layer: half the two-layer sum here (identical layers).
  DregLossOptions last;
  last.all_layers = false;
  EXPECT_NEAR(DregLoss(Build(true), src_, tgt_, gt_, last).confidence.item<double>(),
              0.5 * good.confidence.item<double>(), 1e-6);
}

TEST_F(DregLossTest, GradientsReachWAndTheMatchesThroughTheSurfaceTerm) {
  DregOutput out = Build(false, 1);
  const DregLossTerms terms = DregLoss(out, src_, tgt_, gt_);
  terms.feature.backward({}, /*retain_graph=*/true);
  ASSERT_TRUE(out.feature_w.grad().defined());
  EXPECT_GT(out.feature_w.grad().abs().sum().item<double>(), 0.0);
  // The surface term alone has a non-zero gradient w.r.t. the matches (near the surface).
  DregOutput near = Build(true, 1);
  near.src_corr[0] = (near.src_corr[0].detach() + 0.03 * torch::randn_like(near.src_corr[0])).requires_grad_(true);
  const DregLossTerms t2 = DregLoss(near, src_, tgt_, gt_);
  t2.surface.backward();
  ASSERT_TRUE(near.src_corr[0].grad().defined());
  EXPECT_GT(near.src_corr[0].grad().abs().sum().item<double>(), 0.0);
  EXPECT_TRUE(torch::isfinite(near.src_corr[0].grad()).all().item<bool>());
}

TEST_F(DregLossTest, SurfaceTermGradientMatchesFiniteDifferences) {
  DregOutput out = Build(true, 1);
  torch::Tensor corr = (out.src_corr[0].detach().to(torch::kDouble) + 0.02).requires_grad_(true);
  RegGrid tgt64 = tgt_;
  tgt64.surface = tgt_.surface.to(torch::kDouble);
  auto f = [&](const torch::Tensor& c) { return SampleSurface(tgt64, c).square().sum(); };
  f(corr).backward();
  const torch::Tensor g = corr.grad();
  const double h = 1e-6;
  for (int n : {0, 3, 7}) {
    for (int a = 0; a < 3; ++a) {
      torch::Tensor plus = corr.detach().clone(), minus = corr.detach().clone();
      plus[n][a] += h;
      minus[n][a] -= h;
      const double fd = (f(plus).item<double>() - f(minus).item<double>()) / (2 * h);
      EXPECT_NEAR(g[n][a].item<double>(), fd, 1e-5 * (1.0 + std::abs(fd)));
    }
  }
}

TEST_F(DregLossTest, ConfidenceLossFollowsTheLabelNotTheOtherWayRound) {
  // Where S = 0 a confident prediction must be penalised (the original's swapped BCE was not).
  DregOutput out = Build(true, 1);
  out.src_surface = torch::zeros_like(out.src_surface);
  out.tgt_surface = torch::zeros_like(out.tgt_surface);
  out.src_conf_logits[0] = torch::full_like(out.src_conf_logits[0], 8.0);
  out.tgt_conf_logits[0] = torch::full_like(out.tgt_conf_logits[0], 8.0);
  const double confident = DregLoss(out, src_, tgt_, gt_).confidence.item<double>();
  out.src_conf_logits[0] = torch::full_like(out.src_conf_logits[0], -8.0);
  out.tgt_conf_logits[0] = torch::full_like(out.tgt_conf_logits[0], -8.0);
  const double unsure = DregLoss(out, src_, tgt_, gt_).confidence.item<double>();
  EXPECT_GT(confident, 7.0);
  EXPECT_LT(unsure, 0.01);
}

TEST_F(DregLossTest, InfoNceIgnoresNeighboursInsideTheNegativeRadius) {
  // One source keypoint at the origin; target keypoints: its positive (0.05 away), a neighbour at
  // `neighbour_x` with the anchor's own feature, and a far point with an orthogonal feature.
  // Identity ground truth, W = I. Inside r_n = 0.4 the neighbour is left out of the denominator;
  // beyond it, it is a negative as strong as the positive (+ ~log 2 on the anchor's term).
  auto feature_loss = [&](double neighbour_x) {
    DregOutput out;
    out.src_xyz = torch::zeros({1, 3});
    out.tgt_xyz =
        torch::tensor({{0.05f, 0.0f, 0.0f}, {static_cast<float>(neighbour_x), 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}});
    out.src_surface = torch::ones({1});
    out.tgt_surface = torch::ones({3});
    const torch::Tensor a = torch::tensor({{2.0f, 0.0f}}), b = torch::tensor({{0.0f, 2.0f}});
    out.src_features = {a};
    out.tgt_features = {torch::cat({a, a, b})};
    out.src_corr = {out.src_xyz};
    out.tgt_corr = {out.tgt_xyz};
    out.src_conf_logits = {torch::zeros({1})};
    out.tgt_conf_logits = {torch::zeros({3})};
    out.src_conf = {torch::full({1}, 0.5)};
    out.tgt_conf = {torch::full({3}, 0.5)};
    out.rotation = {torch::eye(3)};
    out.translation = {torch::zeros({3})};
    out.scale = {torch::ones({})};
    out.pose_valid = {torch::ones({}, torch::kBool)};
    out.feature_w = torch::eye(2);
    return DregLoss(out, src_, tgt_, torch::eye(4)).feature.item<double>();
  };
  const double ignored = feature_loss(0.3);
  const double negative = feature_loss(0.6);
  // Anchors: the source point and the target positive (the other target points have no source
  // point within r_p). With the neighbour ignored both terms are ~0 (e^-4 residue).
  EXPECT_LT(ignored, 0.02);
  EXPECT_NEAR(negative, 0.5 * std::log(2.0), 0.02);
}

TEST_F(DregLossTest, SeenSurfaceIsTheSurfaceDilatedByOneVoxel) {
  const torch::Tensor on = src_.xyz.index({src_.surface > 0.9});
  ASSERT_GT(on.size(0), 10);
  // At least the surface itself, and one voxel off a seen voxel still reads as seen.
  EXPECT_TRUE((SampleSeenSurface(src_, on) >= SampleSurface(src_, on) - 1e-5).all().item<bool>());
  const torch::Tensor off = on + torch::tensor({src_.CellSize(), 0.0, 0.0}).to(torch::kFloat);
  EXPECT_GT(SampleSeenSurface(src_, off).mean().item<float>(), 0.9f);
  EXPECT_EQ(SampleSeenSurface(src_, torch::tensor({{2.0f, 0.0f, 0.0f}})).item<float>(), 0.0f);
  EXPECT_LT(SampleSeenSurface(src_, torch::tensor({{1.3f, 1.3f, 1.3f}})).item<float>(), 1e-6f);
}

// The target block saw only its x < 0 half: source keypoints whose true match lies in the other
// half have no match. With overlap_labels their confidence label is 0 and their correspondence
// error does not count; the paper's labels ask them for a confident match.
TEST_F(DregLossTest, OverlapLabelsLeaveOutWhatTheOtherBlockDidNotSee) {
  const torch::Tensor right = tgt_.xyz.select(3, 0) > 0.0;  // [D, D, D] in the target's frame
  tgt_.surface = tgt_.surface.masked_fill(right, 0.0f);
  tgt_.mask = tgt_.mask.logical_and(right.logical_not());
  tgt_.rgba = tgt_.rgba.masked_fill(right.unsqueeze(0), 0.0f);
  DregOutput perfect = Build(true, 1);  // confidence = S, every match at its true position
  const torch::Tensor src_in_tgt = Apply(gt_, perfect.src_xyz);
  const torch::Tensor unseen = src_in_tgt.select(1, 0) > 3 * tgt_.CellSize();  // well inside the cut half
  const torch::Tensor seen = src_in_tgt.select(1, 0) < -2 * tgt_.CellSize();
  ASSERT_GT(unseen.sum().item<int64_t>(), 5);
  ASSERT_GT(seen.sum().item<int64_t>(), 5);
  // Scatter the unseen points' matches: they cannot be matched anyway.
  DregOutput scattered = Build(true, 1);
  scattered.src_corr[0] = torch::where(unseen.unsqueeze(1), src_in_tgt + 1.0, src_in_tgt).requires_grad_(true);
  // ... and give them confidence 0, as the overlap labels ask.
  DregOutput overlap_aware = Build(true, 1);
  overlap_aware.src_conf_logits[0] = overlap_aware.src_conf_logits[0].masked_fill(unseen, -9.0);

  DregLossOptions paper, ours;
  ours.overlap_labels = true;
  // Correspondence: the scattered unseen matches cost the paper's loss and (nearly) not ours.
  const double paper_cost = DregLoss(scattered, src_, tgt_, gt_, paper).correspondence.item<double>();
  const double ours_cost = DregLoss(scattered, src_, tgt_, gt_, ours).correspondence.item<double>();
  EXPECT_GT(paper_cost, 0.05);
  EXPECT_LT(ours_cost, 0.1 * paper_cost);
  // Confidence: S is the paper's optimum; zero on the unseen points scores better with ours.
  EXPECT_LT(DregLoss(perfect, src_, tgt_, gt_, paper).confidence.item<double>(),
            DregLoss(overlap_aware, src_, tgt_, gt_, paper).confidence.item<double>());
  EXPECT_LT(DregLoss(overlap_aware, src_, tgt_, gt_, ours).confidence.item<double>(),
            DregLoss(perfect, src_, tgt_, gt_, ours).confidence.item<double>());
  // Where both blocks saw the surface, nothing changes: the labels agree on the seen points.
  const torch::Tensor o = SampleSeenSurface(tgt_, src_in_tgt);
  EXPECT_GT(o.masked_select(seen).mean().item<float>(), 0.9f);
  EXPECT_LT(o.masked_select(unseen).max().item<float>(), 1e-6f);
}

}  // namespace
}  // namespace nerfreg
