#pragma once
// Splitting a trajectory into blocks as DReg-NeRF does: k-means on camera centres, every 20th
// image of a block held out for testing, and each block moved into its own random frame.
#include <random>
#include <vector>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

// Deterministic k-means (k-means++ seeding from `seed`, Lloyd iterations). Returns a cluster per
// point; clusters are renumbered by their smallest member index so block 0 holds point 0.
std::vector<int> KMeans(const std::vector<Eigen::Vector3d>& points, int k, unsigned seed, int iterations = 100);

struct BlockFrameOptions {
  // Rotation: DReg-NeRF draws xi ~ N(0, I6) and keeps the rotation unbounded (mean ~92 deg).
  // A positive max_rotation_deg caps the angle instead.
  double max_rotation_deg = -1;
  double max_translation = 0.2;             // each translation coordinate clamped to [-x, x]
  double min_scale = 1.0, max_scale = 1.0;  // Sim(3) scale drawn uniformly in [min, max]
  void Check() const;
};

// A random block_from_world transform.
Sim3d RandomBlockFrame(const BlockFrameOptions& options, std::mt19937& rng);

}  // namespace nerfreg
