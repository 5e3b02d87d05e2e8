#pragma once
// A trained block as 3D Gaussian splats (`nerf export --splats`): one isotropic Gaussian per
// occupied cell whose density exceeds min_density (ExtractOccupiedPoints: one jittered point per
// cell of the occupancy grid), standard deviation half a cell, colour the field's view-averaged
// colour as the DC term (SH degree 0), opacity the alpha of one cell, 1 - exp(-sigma cell), kept
// within [0.01, 0.99]. Positions, sizes and densities are in the block's frame (world_from_field
// applied). A splat file other tools load, and an input `reg register` takes beside the block.
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/nerf/nerf_block.h"

namespace nerfreg {

struct BlockSplatOptions {
  double min_density = 5.0;  // --density: as `nerf export --points`
  unsigned seed = 0;         // the points' jitter
  void Check() const;        // throws InputError naming the option
};

Splats BlockToSplats(NerfBlock& block, const BlockSplatOptions& options);

}  // namespace nerfreg
