#pragma once
// The voxel grid DReg-NeRF registers (spec dreg-nerf.md 3): what one NeRF block looks like to the
// registration network, extracted once from the block's field (reg/grid_extraction.h) or
// synthesised from a mesh for extra training data, and cached on disk.
//
// Layout: a cubic grid of D^3 voxels over [aabb_min, aabb_max] in the block's frame. Tensor index
// [..., i, j, k] is the voxel whose centre is aabb_min + (i + 0.5, j + 0.5, k + 0.5) * cell along
// (x, y, z), the same order as nerf/occupancy_grid.h. (To sample with torch::grid_sample, whose
// last grid coordinate indexes dim 2 of a [N, C, D, H, W] input, pass normalised (z, y, x).)
#include <torch/torch.h>

#include <Eigen/Core>
#include <array>
#include <string>

namespace nerfreg {

constexpr int kRegGridVersion = 1;

struct RegGrid {
  // [4, D, D, D] float32: RGB averaged over view directions and alpha = clip(1 - exp(-0.01 sigma),
  // 0, 1) at each voxel's sample point; zero where the voxel is not occupied. The CNN's input.
  torch::Tensor rgba;
  // [D, D, D, 3] float32: each voxel's (jittered) sample point in the block's frame. The
  // keypoints' coordinates come from here, not from the voxel centres.
  torch::Tensor xyz;
  // [D, D, D] float32 in [0, 1]: the surface field S (probability that a training camera's ray
  // hits a surface at the voxel). The confidence and correspondence labels.
  torch::Tensor surface;
  // [D, D, D] bool: the voxels the network sees: density > threshold AND S >= 0.5 (the paper's
  // mask), or density alone for the "df" variant.
  torch::Tensor mask;
  Eigen::Vector3d aabb_min = Eigen::Vector3d::Constant(-1.5);
  Eigen::Vector3d aabb_max = Eigen::Vector3d::Constant(1.5);
  // Where the grid came from: "nerf" (a trained block) or "mesh" (synthesised), and the variant
  // ("surface" or "df"); written next to results so a table says what it measured.
  std::string source = "nerf";
  std::string variant = "surface";

  int Resolution() const { return static_cast<int>(surface.size(0)); }
  double CellSize() const { return (aabb_max.x() - aabb_min.x()) / Resolution(); }
  // [M, 3] keypoints, [M] surface labels, [M, 4] rgba at the mask, in mask.nonzero() order.
  torch::Tensor MaskedXyz() const;
  // [D, D, D] bool: the occupied voxels (alpha > 0: density over the extraction's threshold), a
  // superset of the mask; [K, 3] their sample points.
  torch::Tensor Occupied() const;
  torch::Tensor OccupiedXyz() const;
  torch::Tensor MaskedSurface() const;
  // Throws std::invalid_argument when shapes, dtypes or the box are inconsistent.
  void Check() const;
};

// [N, 3] points (any float dtype) as a [3, N] Eigen matrix (the classical and geometric code's
// layout), e.g. PointsToEigen(grid.MaskedXyz()).
Eigen::Matrix3Xd PointsToEigen(const torch::Tensor& xyz);

// Grids are torch archives with a format tag and version; written atomically. Load throws
// InputError naming the file when it is missing, truncated, not a grid, or of another version.
void SaveRegGrid(const RegGrid& grid, const std::string& path);
RegGrid LoadRegGrid(const std::string& path);

// The grid seen from another frame: new_from_old = (rotation, translation). The box keeps its
// size and follows its centre; the content is resampled (each new voxel takes the old voxel its
// centre maps back into; sample points are jittered in their new cells), so the masked surface is
// the same surface in the new frame. Used to augment training pairs (the CNN sees a rotated grid)
// and to test that registration recovers a known transform of the same grid.
RegGrid TransformRegGrid(const RegGrid& grid, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

// The grid mirrored x -> 2 c_x - x about its box's centre c: voxels flipped along x exactly (no
// resampling), sample points mirrored. *mirrored_from_grid (optional) receives that reflection as a
// 4x4 matrix (its own inverse). Mirroring both grids of a pair gives the pair of the mirrored
// object, related by mirrored_target_from_target * target_from_source * mirrored_source_from_source,
// a proper rotation again: a training augmentation (reg train --mirror).
RegGrid MirrorRegGrid(const RegGrid& grid, Eigen::Matrix4d* mirrored_from_grid = nullptr);
// Both grids of a pair mirrored in place, target_from_source updated to relate the mirrored pair.
void MirrorRegGridPair(RegGrid* source, RegGrid* target, Eigen::Matrix4d* target_from_source);

// The grid recoloured: new RGB channel c = clamp(gain[c] * old channel permutation[c], 0, 1) where
// the grid has colour; alpha, geometry and masks kept. A training augmentation (reg train --recolour).
RegGrid RecolourRegGrid(const RegGrid& grid, const std::array<std::int64_t, 3>& permutation,
                        const std::array<double, 3>& gain);

// The overlap of a pair under a transform: the fraction of source mask points that land within
// one cell of a target mask voxel.
double GridOverlap(const RegGrid& source, const RegGrid& target, const Eigen::Matrix4d& target_from_source);

}  // namespace nerfreg
