#include "nerfreg/posegraph/pose_graph.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace nerfreg {
namespace {

// Node 0 at the identity, the others at random poses; with `scales`, node k's scale is scales[k].
std::vector<Sim3d> RandomPoses(std::mt19937& rng, int n, const std::vector<double>& scales = {}) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Sim3d> poses(n);
  for (int k = 1; k < n; ++k) {
    poses[k] = Sim3d(scales.empty() ? 1.0 : scales[k], RandomRotation(u(rng), u(rng), u(rng)),
                     Eigen::Vector3d(u(rng), u(rng), u(rng)) * 2);
  }
  return poses;
}

// j_from_i from the true poses, perturbed by a random rigid motion (and log-scale) of size `noise`.
PoseGraphEdge Measure(const std::vector<Sim3d>& world_from, int i, int j, std::mt19937& rng, double noise) {
  std::normal_distribution<double> g(0, noise);
  Vector6d xi;
  for (int k = 0; k < 6; ++k) xi(k) = g(rng);
  PoseGraphEdge e;
  e.i = i;
  e.j = j;
  e.j_from_i = Sim3d(Rigid3d::Exp(xi)) * (world_from[j].Inverse() * world_from[i]);
  e.j_from_i.scale *= std::exp(g(rng));
  return e;
}

TEST(PoseGraph, RecoversPosesFromNoisyLoopAndRejectsAnOutlier) {
  std::mt19937 rng(5);
  const int n = 6;
  const auto gt = RandomPoses(rng, n);
  std::vector<PoseGraphEdge> edges;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) edges.push_back(Measure(gt, i, j, rng, 0.003));
  // One grossly wrong registration, with a high weight so the spanning tree may even pick it.
  PoseGraphEdge bad = Measure(gt, 2, 4, rng, 0.0);
  bad.j_from_i =
      Sim3d(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitX())), Eigen::Vector3d(1, 1, 1)) *
      bad.j_from_i;
  edges.push_back(bad);
  const std::vector<double> support = TriangleSupport(n, edges, 5.0, 0.1);
  EXPECT_EQ(support.back(), 0.0);  // the wrong edge closes no consistent triangle
  EXPECT_GE(support.front(), n - 3.0);
  const PoseGraphResult r = OptimizePoseGraph(n, edges, PoseGraphOptions{});
  for (int k = 0; k < n; ++k) {
    ASSERT_TRUE(r.connected[k]);
    EXPECT_LT(RotationErrorDeg(r.world_from_node[k].rotation, gt[k].rotation), 0.5) << k;
    EXPECT_LT(TranslationError(r.world_from_node[k].translation, gt[k].translation), 0.02) << k;
  }
  EXPECT_FALSE(r.edge_inlier.back());
  int inliers = 0;
  for (bool b : r.edge_inlier) inliers += b;
  EXPECT_EQ(inliers, static_cast<int>(edges.size()) - 1);
}

// A block of another object: its registrations to the others are arbitrary, so the loops through
// it disagree. They are dropped until every remaining edge agrees; the true blocks keep their
// poses and their own edges.
TEST(PoseGraph, EdgesThatDisagreeWithTheirLoopsAreDropped) {
  std::mt19937 rng(7);
  const int n = 4;
  const auto gt = RandomPoses(rng, n);
  std::vector<PoseGraphEdge> edges = {Measure(gt, 0, 1, rng, 0.002), Measure(gt, 0, 2, rng, 0.002),
                                      Measure(gt, 1, 2, rng, 0.002)};
  const auto other = RandomPoses(rng, n);  // block 3 registered as if it were somewhere else
  for (int i = 0; i < 3; ++i) {
    PoseGraphEdge e = Measure(other, i, 3, rng, 0.0);
    e.j_from_i = Sim3d(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(1.0 + i, Eigen::Vector3d(1, i, 2).normalized())),
                       Eigen::Vector3d(0.5 * i, 1, -1)) *
                 e.j_from_i;
    edges.push_back(e);
  }
  std::vector<bool> dropped;
  const PoseGraphResult r = OptimizePoseGraphWithoutOutliers(n, edges, PoseGraphOptions{}, &dropped);
  ASSERT_EQ(dropped.size(), edges.size());
  EXPECT_FALSE(dropped[0] || dropped[1] || dropped[2]);
  EXPECT_GE(dropped[3] + dropped[4] + dropped[5], 2);  // at most one, a tree edge, is left
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(RotationErrorDeg(r.world_from_node[k].rotation, gt[k].rotation), 0.5) << k;
  }
  for (size_t k = 0; k < edges.size(); ++k) EXPECT_EQ(r.edge_inlier[k], !dropped[k]) << k;
  // A consistent graph loses nothing.
  const std::vector<PoseGraphEdge> good(edges.begin(), edges.begin() + 3);
  OptimizePoseGraphWithoutOutliers(n - 1, good, PoseGraphOptions{}, &dropped);
  EXPECT_EQ(dropped, std::vector<bool>(3, false));
}

// Captures at different scales (issue 43): every node has its own unit, each edge measures the
// relative similarity with noise, around a loop and across it. The Sim(3) graph recovers every
// node's scale, rotation and translation; the rigid graph (scales fixed at 1) cannot.
TEST(PoseGraph, Sim3GraphRecoversKnownScalesAroundALoop) {
  std::mt19937 rng(11);
  const int n = 5;
  const std::vector<double> scales = {1.0, 0.4, 2.5, 0.7, 1.6};
  const auto gt = RandomPoses(rng, n, scales);
  std::vector<PoseGraphEdge> edges;
  for (int i = 0; i < n; ++i) edges.push_back(Measure(gt, i, (i + 1) % n, rng, 0.003));  // the loop
  edges.push_back(Measure(gt, 0, 2, rng, 0.003));
  edges.push_back(Measure(gt, 1, 3, rng, 0.003));
  std::vector<bool> dropped;
  const PoseGraphResult r = OptimizePoseGraphWithoutOutliers(n, edges, PoseGraphOptions{}, &dropped);
  EXPECT_EQ(dropped, std::vector<bool>(edges.size(), false));
  for (int k = 0; k < n; ++k) {
    ASSERT_TRUE(r.connected[k]);
    EXPECT_NEAR(r.world_from_node[k].scale / gt[k].scale, 1.0, 0.01) << k;
    EXPECT_LT(RotationErrorDeg(r.world_from_node[k].rotation, gt[k].rotation), 0.5) << k;
    EXPECT_LT(TranslationError(r.world_from_node[k].translation, gt[k].translation), 0.02) << k;
  }
  for (size_t k = 0; k < edges.size(); ++k) {
    EXPECT_TRUE(r.edge_inlier[k]) << k;
    EXPECT_LT(r.edge_log_scale_error[k], 0.02) << k;
  }

  // The same edges in a rigid graph: the nodes keep scale 1, so the translations cannot close
  // the loops and the graph does not recover the poses.
  PoseGraphOptions rigid;
  rigid.estimate_scale = false;
  const PoseGraphResult f = OptimizePoseGraph(n, edges, rigid);
  double worst = 0;
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(f.world_from_node[k].scale, 1.0);
    worst = std::max(worst, TranslationError(f.world_from_node[k].translation, gt[k].translation));
  }
  EXPECT_GT(worst, 0.2);
}

// An edge whose scale alone is wrong (a registration that found the right turn at a wrong size)
// closes no loop and is dropped.
TEST(PoseGraph, AnEdgeWithAWrongScaleIsDropped) {
  std::mt19937 rng(12);
  const int n = 4;
  const auto gt = RandomPoses(rng, n, {1.0, 0.5, 2.0, 3.0});
  std::vector<PoseGraphEdge> edges;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) edges.push_back(Measure(gt, i, j, rng, 0.002));
  edges[4].j_from_i.scale *= 1.5;  // 1 -> 3
  std::vector<bool> dropped;
  const PoseGraphResult r = OptimizePoseGraphWithoutOutliers(n, edges, PoseGraphOptions{}, &dropped);
  for (size_t k = 0; k < edges.size(); ++k) EXPECT_EQ(dropped[k], k == 4) << k;
  for (int k = 0; k < n; ++k) EXPECT_NEAR(r.world_from_node[k].scale / gt[k].scale, 1.0, 0.01) << k;
}

TEST(PoseGraph, DisconnectedNodesAreFlagged) {
  std::mt19937 rng(6);
  const auto gt = RandomPoses(rng, 4);
  std::vector<PoseGraphEdge> edges = {Measure(gt, 0, 1, rng, 0), Measure(gt, 2, 3, rng, 0)};
  const PoseGraphResult r = OptimizePoseGraph(4, edges, PoseGraphOptions{});
  EXPECT_TRUE(r.connected[1]);
  EXPECT_FALSE(r.connected[2]);
  EXPECT_FALSE(r.connected[3]);
  EXPECT_LT(RotationErrorDeg(r.world_from_node[1].rotation, gt[1].rotation), 1e-6);
}

TEST(PoseGraph, BadEdgesThrow) {
  PoseGraphEdge e;
  e.i = 0;
  e.j = 5;
  EXPECT_THROW(OptimizePoseGraph(2, {e}, PoseGraphOptions{}), std::invalid_argument);
  e.j = 0;
  EXPECT_THROW(OptimizePoseGraph(2, {e}, PoseGraphOptions{}), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
