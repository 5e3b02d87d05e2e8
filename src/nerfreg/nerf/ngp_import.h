#pragma once
// instant-ngp snapshot -> NeRF block (`nerfreg nerf import`): the field reproduces ngp's model
// (field flavor "instant-ngp": tiny-cuda-nn's grid rule, exp density, ngp's colour input), the
// occupancy grid comes from ngp's density grid, and the block carries cameras when given.
//
// The block's frame (NgpImportOptions::frame):
//  - "nerf" (default): the frame of the transforms.json the snapshot was trained on. instant-ngp
//    maps it into its unit space as x_ngp = cycle(scale * x + offset), cycle(v) = (v.y, v.z, v.x)
//    (nerf_matrix_to_ngp); the imported field applies the inverse, so the block, its AABB and the
//    transforms.json cameras agree and `nerf render` / registration use those cameras as they are.
//    Densities are per block length: sigma = scale * sigma_ngp. scale / offset come from the
//    snapshot (nerf.dataset) when stored, else from the --transforms file, else ngp's defaults
//    (0.33, [0.5, 0.5, 0.5]).
//  - "ngp": instant-ngp's internal unit space (the snapshot's aabb as is); cameras given are moved
//    into it.
#include <string>

#include "nerfreg/data/dataset.h"
#include "nerfreg/data/ngp_snapshot.h"
#include "nerfreg/nerf/nerf_block.h"

namespace nerfreg {

struct NgpImportOptions {
  std::string frame = "nerf";  // "nerf" or "ngp" (above)
  // A density-grid cell is occupied when its value (ngp's optical thickness density * step)
  // exceeds min(threshold, mean of cascade 0), as instant-ngp marks its bitfield.
  double occupancy_threshold = 0.01;
  // Ray-marching step over the block's AABB: its largest side * sqrt(3) / steps_per_aabb
  // (instant-ngp marches sqrt(3)/1024 per unit cube).
  int steps_per_aabb = 1024;
  void Check() const;  // throws std::invalid_argument
};

// The world -> ngp similarity the import used: x_ngp[k] = scale * x[axis_order[k]] + offset[axis_order[k]].
struct NgpFrame {
  double scale = 1;
  std::array<double, 3> offset{0, 0, 0};
  std::array<int, 3> axis_order{0, 1, 2};
};
NgpFrame ImportFrame(const NgpSnapshot& snapshot, const NgpImportOptions& options, const Dataset* cameras);

// `source` names the snapshot in errors (InputError for configurations the field cannot express,
// e.g. MLPs of different widths). `cameras`: optional, in the transforms.json frame.
NerfBlock SnapshotToNerfBlock(const NgpSnapshot& snapshot, const std::string& source,
                              const NgpImportOptions& options = {}, const Dataset* cameras = nullptr);

}  // namespace nerfreg
