#pragma once
// For tests: a NeRF small enough to train in seconds on one core (the "fast" preset with a 2^14
// hash table, 8 levels, a 32^3 occupancy grid, 8192 samples per step, no evaluation or checkpoints
// on the way).
#include "nerfreg/nerf/trainer.h"

namespace nerfreg {

inline NerfTrainOptions TinyNerfTrainOptions(int iterations) {
  NerfTrainOptions o = NerfTrainOptions::Preset("fast");
  o.iterations = iterations;
  o.field.encoding.log2_table_size = 14;
  o.field.encoding.levels = 8;
  o.field.encoding.per_level_scale = 1.5;
  o.grid.resolution = 32;
  o.target_samples = 1 << 13;
  o.eval_every = 0;
  o.checkpoint_every = 0;
  return o;
}

}  // namespace nerfreg
