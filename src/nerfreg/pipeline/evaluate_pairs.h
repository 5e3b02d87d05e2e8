#pragma once
// `reg eval --pairs`'s job: every method, solver, pass count and refinement on every pair of a
// reg make-data folder, each row's errors against the pair's truth. Each row runs reg register's
// chain (registration/registration_chain.h) on the pair's grids: the method, ICP on the grids,
// then on the blocks' occupied points (block-icp), then the fields aligned (field); the last two
// need the blocks (real pairs keep block_K.ckpt beside block_K.grid) and are skipped, with one
// warning, on synthesised pairs.
#include <functional>
#include <string>
#include <vector>

#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg_train/pairs.h"
#include "nerfreg/registration/registration_options.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// A row's method: a registration method on the grids, or kTruth (each refinement started at the
// ground truth: where it ends is the floor the two blocks' own disagreement sets).
// kAuto: reg register's whole chain (RegisterBlocks: the normalisation with base.scale kFree, every
// candidate, the choice) on a real pair's blocks, so the row is exactly what reg register gives.
enum class PairMethod { kDreg, kRansac, kFgr, kTruth, kAuto };
// How far along the chain a row goes: kNone (the method alone), kIcp (ICP on the grids), kBlockIcp
// (then on the blocks' occupied points), kField (then the fields aligned).
enum class PairRefinement { kNone, kIcp, kBlockIcp, kField };
// As --methods and --refine spell them ("dreg", ..., "truth"; "none", "icp", "block-icp",
// "field"); FromName throws InputError naming `option`.
std::string PairMethodName(PairMethod method);
std::string PairRefinementName(PairRefinement refinement);
PairMethod PairMethodFromName(const std::string& name, const std::string& option = "--methods");
PairRefinement PairRefinementFromName(const std::string& name, const std::string& option = "--refine");

struct PairEvaluationOptions {
  std::vector<PairMethod> methods = {PairMethod::kRansac};           // --methods
  std::vector<PairRefinement> refines = {PairRefinement::kIcp};      // --refine
  std::vector<DregSolver> dreg_solvers = {DregSolver::kProcrustes};  // --dreg-solver (dreg rows only)
  std::vector<int> dreg_passes = {1};                                // --dreg-passes (dreg rows only)
  // The chain's options every row starts from: the grid ICP's points, distance and half-turns
  // (--icp-points, --icp-distance, --no-flips), --voxel, the field refinement's
  // (--field-overlap-only); method, refine and the dreg solve are set per row. base.scale
  // (--scale) is used by the auto rows only: the others run rigid on grids that share a unit.
  BlockRegistrationOptions base;
  torch::Device device = torch::kCPU;  // --device: the blocks' fields (the caller moves the network)
  void Check() const;                  // throws InputError naming the flag
};

struct PairEvaluation {
  std::string pair, method;  // method: e.g. "dreg+icp+block+field"
  double rotation_deg = 0;   // geodesic, against the pair's truth
  double translation = 0;    // full norm of the difference, scene units
  double seconds = 0, confidence = 0, overlap = 0;
  std::string kept, status;  // auto rows: the candidate reg register kept, and its status
};

// `net`: needed when methods holds dreg. `on_row` (optional) sees each row as it is made.
std::vector<PairEvaluation> EvaluatePairs(const std::vector<PairRecord>& pairs, const PairEvaluationOptions& options,
                                          DregNet* net, const std::function<void(const PairEvaluation&)>& on_row = {});

// The summary per method of rows: mean, median, success at 5 deg / 0.05 and 10 deg / 0.1 of the
// extent, and successes by overlap (below / at or above overlap_threshold), as JSON and as the
// table `reg eval --pairs` prints (the by-overlap table only when the pairs mix overlaps).
struct PairSummary {
  Json json;
  std::string table;
};
PairSummary SummarisePairEvaluations(const std::vector<PairEvaluation>& rows, double overlap_threshold);

// `reg eval --pairs` as a whole: the pairs of `split` ("all": every one; at most max_pairs when > 0)
// of a pairs.json evaluated (the network loaded from `weights` when a method needs it), summarised
// and, with `out`, written there.
struct PairsFileEvaluationOptions {
  std::string pairs_path, split = "val", weights, out;
  int max_pairs = 0;
  double overlap_threshold = 0.8;
  PairEvaluationOptions evaluation;
};
struct PairsFileEvaluation {
  std::vector<PairEvaluation> rows;
  PairSummary summary;
};
// `on_start` (optional) runs once the pairs and the network are loaded, before the first row.
PairsFileEvaluation EvaluatePairsFile(const PairsFileEvaluationOptions& options,
                                      const std::function<void()>& on_start = {},
                                      const std::function<void(const PairEvaluation&)>& on_row = {});

// `reg eval --pair`: one registration output (T.json of reg register) against the ground truth
// (ground_truth.json of the rendered dataset: blocks[k].block_from_world) of source block `source`
// and target block `target`; with `out`, the errors are written there. The blocks default to 0 -> 1,
// so a result registered the other way (reg register b1 b0) scored without --source 1 --target 0
// reads as a wrong pose (bench/registration_sim3.sh once reported a right one 97 deg off that
// way): a result that fails against source -> target but succeeds against target -> source is
// flagged (matches_swapped, and a warning naming the options).
struct RegistrationError {
  double rotation_deg = 0, translation = 0, translation_fraction = 0;  // fraction of the object extent
  bool success = false;                                                // 5 deg and 0.05 of the extent
  double scale = 1, true_scale = 1, scale_error = 0;  // the result's, the truth's, |scale / true_scale - 1|
  bool matches_swapped = false;                       // fails as source -> target, succeeds as target -> source
  std::string method = "?";
  Json json;
};
RegistrationError EvaluateRegistrationFile(const std::string& pair_path, const std::string& ground_truth_path,
                                           int source, int target, const std::string& out = "");

}  // namespace nerfreg
