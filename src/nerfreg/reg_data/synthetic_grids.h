#pragma once
// Registration training pairs synthesised from a mesh without training any NeRF: what a block's
// NeRF would see, with NeRF-like artefacts. Training enough real blocks costs ~3 minutes each on
// 2 CPU cores; these cost well under a second per pair, so they are the bulk of the training data,
// while evaluation always uses real trained blocks (reg make-data --nerf-objects).
//
// Per block (the DReg-NeRF data pipeline, spec dreg-nerf.md 2): the orbit trajectory is split by
// k-means on camera centres; every view of the block is ray-cast (depth + colour), its surface
// pixels are back-projected, moved into the block's random frame and voxelised on the same grid
// as reg/grid_extraction.h (a cube of fixed side around the object's box in the block frame):
//  - seen surface voxels: density, S = 1, colour = mean seen colour, alpha from a NeRF-like
//    density distribution;
//  - blur: surface voxels dilated by one cell with probability `blur`, with a partial S;
//  - floaters: small clusters of density in the free space in front of the block's cameras;
//  - unseen regions: nothing (a NeRF knows nothing there), as in real blocks.
#include <Eigen/Core>
#include <random>

#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/render/blocks.h"
#include "nerfreg/render/mesh.h"

namespace nerfreg {

struct SyntheticPairOptions {
  int resolution = 32;  // D, as GridExtractionOptions
  double side = 3.6;    // cube side, as GridExtractionOptions
  int views = 120;      // orbit views (the DReg-NeRF trajectory)
  int image_size = 96;  // ray-cast resolution of each view (the back-projected points)
  int blocks = 2;       // k-means blocks; the pair is (source_block, target_block)
  int source_block = 0, target_block = 1;
  BlockFrameOptions frames;               // random block frames (DReg-NeRF: arbitrary rotations)
  double blur = 0.25;                     // probability that a surface voxel spreads to a 6-neighbour
  int floaters = 12;                      // floater clusters per block
  double min_sigma = 5, max_sigma = 400;  // log-uniform density of occupied voxels (alpha channel)
  // Scale augmentation in the frame `reg register --scale free` gives the network: when > 0, the
  // source block's frame is scaled by a relative scale drawn log-uniformly in [1 / x, x] (1: none),
  // and then each block is moved into its own normalised frame as the register path moves an input
  // (registration/scale_normalization.h: centred on its seen surface points, RMS radius
  // kNormalizedRadius) before it is voxelised. The pair's truth then carries the residual scale
  // between what the two blocks saw. 0: off, both blocks in the mesh's unit (the shipped data).
  double max_relative_scale = 0;
  void Check() const;  // throws std::invalid_argument
};

struct GridPair {
  RegGrid source, target;
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double overlap = 0;  // fraction of the source mask within one cell of the target mask (true pose)
  // Per block, the scale of its normalisation relative to the mesh's unit (the random relative
  // scale left out): how much larger the register path shows the block than the mesh unit does.
  // 1 without max_relative_scale.
  double source_normalization = 1, target_normalization = 1;
};

// `mesh` is normalised (largest side 2.5, centred), as `nerfreg render` does.
GridPair SyntheticGridPair(const TriangleMesh& mesh, const SyntheticPairOptions& options, unsigned seed);

}  // namespace nerfreg
