#pragma once
// `reg eval --pairs`'s job: every method, solver, pass count and refinement on every pair of a
// reg make-data folder, each row's errors against the pair's truth. The refinements are reg
// register's (pipeline/register_blocks.h): ICP on the grids, then on the blocks' occupied points
// (block-icp), then the fields aligned (field); the last two need the blocks (real pairs keep
// block_K.ckpt beside block_K.grid) and are skipped, with one warning, on synthesised pairs.
#include <functional>
#include <string>
#include <vector>

#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg/register_grids.h"
#include "nerfreg/reg/training_data.h"

namespace nerfreg {

struct PairEvaluationOptions {
  std::vector<std::string> methods = {"ransac"};  // --methods: dreg, ransac, fgr, truth (each refinement from the truth)
  std::vector<std::string> refines = {"icp"};     // --refine: none, icp, block-icp, field
  std::vector<std::string> dreg_solvers = {"procrustes"};  // --dreg-solver (dreg rows only)
  std::vector<int> dreg_passes = {1};                      // --dreg-passes (dreg rows only)
  GridRegistrationOptions base;  // the grid ICP's points, distance, half-turns and the voxel
  FieldAlignmentOptions field;   // --refine field (--field-overlap-only)
  torch::Device device = torch::kCPU;  // --device: the blocks' fields (the caller moves the network)
  void Check() const;            // throws InputError naming the flag
};

struct PairEvaluation {
  std::string pair, method;  // method: e.g. "dreg+icp+block+field"
  double rotation_deg = 0;   // geodesic, against the pair's truth
  double translation = 0;    // full norm of the difference, scene units
  double seconds = 0, confidence = 0, overlap = 0;
};

// `net`: needed when methods holds dreg. `on_row` (optional) sees each row as it is made.
std::vector<PairEvaluation> EvaluatePairs(const std::vector<PairRecord>& pairs, const PairEvaluationOptions& options,
                                          DregNet* net, const std::function<void(const PairEvaluation&)>& on_row = {});

}  // namespace nerfreg
