#pragma once
// `nerfreg reg make-data`: the registration network's training and evaluation pairs, one object at
// a time, resumable (an object already listed in pairs.json is skipped), its cost reported.
//
//   OUT/pairs.json            {"pairs": [PairRecord...], "objects": {name: {"seconds", "pairs", ...}},
//                              "options": {...}}
//   OUT/<object>/mesh_<k>_{source,target}.grid     synthesised pairs (reg_data/synthetic_grids.h)
//   OUT/<object>/nerf/...                          rendered blocks, block checkpoints, their grids
//                                                  (reg_train/pairs.h trains and pairs them)
//
// Objects are meshes (assimp-testmodels, openscad-testing-data, Sweet Home 3D furniture by split:
// "sh3f:train"; see docs/data.md for the meshes reserved for independent evaluation) and
// procedural objects. Every pair of an object carries the object's split (a furniture model's
// from the split file, else --split), so held-out objects are never trained on.
#include <string>
#include <vector>

#include "nerfreg/nerf/trainer.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/reg_data/sh3f_data.h"
#include "nerfreg/reg_data/synthetic_grids.h"
#include "nerfreg/reg_train/pairs.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct MakeDataOptions {
  // Mesh files (OBJ/PLY/STL/OFF/glTF), or "sh3f:train" / "sh3f:val" / "sh3f:test": the furniture
  // models of that split of sh3f_split_file (reg_data/sh3f_data.h), their pairs in that split.
  std::vector<std::string> meshes;
  std::string sh3f_split_file = "models/sh3f_split.json";  // the committed split
  std::string sh3f_dir = kSh3fFurnitureDir;                // the .sh3f archives
  int sh3f_limit = 0;  // at most this many models of each "sh3f:" split, in the file's order (0: all)
  int procedural = 0;  // procedural objects, seeds procedural_seed .. + n - 1
  unsigned procedural_seed = 1000;
  int mesh_pairs = 4;    // synthesised pairs per object (different random frames)
  int nerf_objects = 0;  // the first n objects also get real trained blocks
  // The nerf objects' blocks are rendered and left untrained: no pairs of them are written (not
  // the synthesised ones either), and the object is listed under "rendered", not "objects", so a
  // later run without it makes its pairs and trains them.
  // For training elsewhere (a GPU machine: bench/gpu_dreg.cc) from the renders alone.
  bool render_only = false;
  int blocks = 2;               // blocks per object (4: fewer views per block; docs/data.md)
  double min_overlap = 0.05;    // pairs of blocks overlapping less are not written
  std::string split = "train";  // the split of every pair written (furniture: its own split)
  int image_size = 100;         // NeRF renders (orbit), pixels
  NerfTrainOptions nerf;        // block training (fast preset by default)
  SyntheticPairOptions synthetic;
  GridExtractionOptions grid;
  unsigned seed = 0;
  void Check() const;  // throws InputError naming the option
  Json ToJson() const;
};

struct MakeDataSummary {
  int objects_done = 0, objects_skipped = 0, pairs = 0;
  double seconds = 0;
};

// Creates OUT when missing; appends to an existing OUT/pairs.json (resume).
MakeDataSummary MakeRegistrationData(const MakeDataOptions& options, const std::string& out_dir);

}  // namespace nerfreg
