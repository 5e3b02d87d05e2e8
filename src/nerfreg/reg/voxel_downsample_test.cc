#include "nerfreg/reg/voxel_downsample.h"

#include <gtest/gtest.h>

namespace nerfreg {
namespace {

class VoxelDownsampleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(2);
    torch::manual_seed(3);
  }
};

TEST_F(VoxelDownsampleTest, AveragesPerCellOnHandExample) {
  // Cell 1.0: points 0 and 1 share cell (0,0,0), point 2 is in (0,0,1), point 3 in (1,0,0).
  const torch::Tensor xyz =
      torch::tensor({{0.1f, 0.2f, 0.3f}, {0.5f, 0.4f, 0.1f}, {0.5f, 0.5f, 1.5f}, {1.2f, 0.1f, 0.1f}});
  const torch::Tensor feat = torch::tensor({{1.0f}, {3.0f}, {5.0f}, {7.0f}});
  const auto out = VoxelAverage(xyz, feat, 1.0);
  ASSERT_EQ(out.xyz.size(0), 3);
  // Sorted by (x, y, z) cell: (0,0,0), (0,0,1), (1,0,0).
  EXPECT_TRUE(torch::allclose(out.xyz, torch::tensor({{0.3f, 0.3f, 0.2f}, {0.5f, 0.5f, 1.5f}, {1.2f, 0.1f, 0.1f}})));
  EXPECT_TRUE(torch::allclose(out.features, torch::tensor({{2.0f}, {5.0f}, {7.0f}})));
}

TEST_F(VoxelDownsampleTest, DeterministicAndInvariantToInputOrder) {
  const torch::Tensor xyz = torch::rand({5000, 3}) * 2.0 - 1.0;
  const torch::Tensor feat = torch::randn({5000, 8});
  const auto a = VoxelAverage(xyz, feat, 0.2);
  const auto b = VoxelAverage(xyz, feat, 0.2);
  EXPECT_TRUE(torch::equal(a.xyz, b.xyz));
  EXPECT_TRUE(torch::equal(a.features, b.features));
  const torch::Tensor perm = torch::randperm(5000);
  const auto c = VoxelAverage(xyz.index_select(0, perm), feat.index_select(0, perm), 0.2);
  ASSERT_EQ(c.xyz.sizes(), a.xyz.sizes());
  // Same cells in the same order; means equal up to summation order.
  EXPECT_TRUE(torch::allclose(c.xyz, a.xyz, 1e-5, 1e-5));
  EXPECT_TRUE(torch::allclose(c.features, a.features, 1e-5, 1e-5));
}

TEST_F(VoxelDownsampleTest, CascadeRespectsBudgetAndKeepsGradients) {
  const torch::Tensor src_xyz = torch::rand({4000, 3}) * 2.5;
  const torch::Tensor tgt_xyz = torch::rand({3000, 3}) * 2.5;
  torch::Tensor src_feat = torch::randn({4000, 4}).requires_grad_(true);
  const torch::Tensor tgt_feat = torch::randn({3000, 4});
  VoxelDownsampleOptions options;
  const auto out = VoxelDownsamplePair(src_xyz, src_feat, tgt_xyz, tgt_feat, options);
  EXPECT_LE(out.src.xyz.size(0) + out.tgt.xyz.size(0), options.max_total_points);
  EXPECT_GT(out.src.xyz.size(0) + out.tgt.xyz.size(0), options.max_total_points / 8);
  EXPECT_GT(out.voxel_size, 0.05);
  out.src.features.sum().backward();
  EXPECT_TRUE(torch::allclose(src_feat.grad().sum(), torch::tensor(4.0f * out.src.xyz.size(0)), 1e-3, 1e-3));
  // Already within budget: unchanged.
  const auto small = VoxelDownsamplePair(src_xyz.slice(0, 0, 100), src_feat.slice(0, 0, 100), tgt_xyz.slice(0, 0, 100),
                                         tgt_feat.slice(0, 0, 100), options);
  EXPECT_EQ(small.voxel_size, 0.0);
  EXPECT_EQ(small.src.xyz.size(0), 100);
}

}  // namespace
}  // namespace nerfreg
