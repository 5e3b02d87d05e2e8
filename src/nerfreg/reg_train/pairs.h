#pragma once
// The registration network's pairs files (OUT/pairs.json of `reg make-data`) and the pairs of real
// trained blocks: an object's rendered blocks trained, their grids extracted, the overlapping ones
// paired. Learned core only (no renderer): `reg make-data` renders and then calls this on the CPU;
// the GPU run (bench/gpu_dreg.cc) calls it on renders made elsewhere and carried.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "nerfreg/nerf/trainer.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct PairRecord {
  std::string name;            // unique within pairs.json
  std::string object;          // the object it was made from
  std::string kind;            // "mesh" (synthesised) or "nerf" (real trained blocks)
  std::string split;           // "train", "val" or "test" (held out: never trained or validated on)
  std::string source, target;  // grid files, relative to the folder of pairs.json
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double overlap = 0;  // GridOverlap under the true pose
  int source_block = 0, target_block = 1, blocks = 2;
  Json ToJson() const;
  static PairRecord FromJson(const JsonField& j);
};

// Reads OUT/pairs.json; file names are made absolute. Throws InputError naming the file/field.
std::vector<PairRecord> ReadPairs(const std::string& pairs_json);

struct BlockPairOptions {
  int blocks = 2;               // the rendered blocks, block_0 .. block_{blocks-1}
  double min_overlap = 0.05;    // pairs of blocks overlapping less are not returned
  std::string split = "train";  // the split of every pair
  NerfTrainOptions nerf;        // block training; its device is where blocks train and grids are extracted
  GridExtractionOptions grid;
  unsigned seed = 0;   // block k trains and is sampled with seed + k
  void Check() const;  // throws InputError naming the option
};

// The pairs of one object's real blocks. OUT/REL/data holds the rendered blocks (ground_truth.json,
// block_k/transforms.json and images, as `nerfreg render --blocks` writes them); block k is trained
// to OUT/REL/block_k.ckpt and its grid extracted to OUT/REL/block_k.grid. Resumable: a grid already
// there is read, not remade, and an unfinished checkpoint is resumed. The pairs name files relative
// to OUT (the folder of pairs.json) and are called OBJECT/nerf_a_b. `cost` (optional) receives
// train_seconds, grid_seconds, psnr_test (one per block trained now) and overlaps (every pair's).
std::vector<PairRecord> TrainBlockPairs(const std::string& out_dir, const std::string& rel, const std::string& object,
                                        const BlockPairOptions& options, Json* cost = nullptr);

}  // namespace nerfreg
