#pragma once
// The registration of two NeRF blocks as one job (COLMAP's controllers/ pattern): everything
// `reg register` decides, behind one options struct and one result, so the choice among methods
// can be tested and the options used are written next to the pose.
//
// The job: each method run gives a candidate pose (dreg: the network on the blocks' grids; ransac
// / fgr: FPFH on the blocks' occupied points; auto: dreg, FPFH + RANSAC on the grids and on the
// occupied points). With refinement each candidate is refined by ICP on the grids, ICP on the
// blocks' occupied points ("block ICP") and, with `kField`, by aligning the two density fields.
// Then one candidate is kept and the result says how far to trust it.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/reg_data/register_grids.h"
#include "nerfreg/reg/registration_input.h"
#include "nerfreg/reg/splat_field.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct NerfBlock;

// The coarse method. kAuto: dreg and FPFH + RANSAC (on the grids and the occupied points), the
// candidate whose fields agree best kept (with kField; else dreg, falling back to ransac).
enum class RegistrationMethod { kAuto, kDreg, kRansac, kFgr };
// kIcp: ICP on the grids, then on the blocks' occupied points; kField: then the fields aligned.
enum class RegistrationRefinement { kNone, kIcp, kField };
// dreg's pose from its correspondences: weighted Kabsch over all (the paper's), or RANSAC.
enum class DregSolver { kProcrustes, kRansac };

// Names as the command line spells them ("auto", "dreg", ...). The *FromName functions throw
// InputError naming `option` ("--method: expected auto, dreg, ransac or fgr").
std::string RegistrationMethodName(RegistrationMethod method);
std::string RegistrationRefinementName(RegistrationRefinement refinement);
std::string DregSolverName(DregSolver solver);
RegistrationMethod RegistrationMethodFromName(const std::string& name, const std::string& option = "--method");
RegistrationRefinement RegistrationRefinementFromName(const std::string& name, const std::string& option = "--refine");
DregSolver DregSolverFromName(const std::string& name, const std::string& option = "--dreg-solver");

// Everything `reg register`'s options set. Each field names its flag.
struct BlockRegistrationOptions {
  RegistrationMethod method = RegistrationMethod::kRansac;         // --method
  RegistrationRefinement refine = RegistrationRefinement::kField;  // --refine
  // --min-confidence: auto without kField falls back to ransac when the network's own score is
  // below this.
  double min_confidence = 0.3;
  // --field-iterations, --field-occupancy-scale, --field-samples (the rest at their defaults;
  // sample_spread is set to the grid's cell).
  FieldAlignmentOptions field;
  // --grid-resolution (dreg, auto: a multiple of 16, the backbone halves it four times).
  GridExtractionOptions grid;
  std::string weights;                  // --weights: recorded only; the caller loads the network
  std::string config;                   // --config: "", "cpu" or "paper" (recorded; checked by the caller)
  double min_density = 5.0;             // --min-density: the occupied points' density threshold
  double voxel = 0.05;                  // --voxel: downsampling voxel, scene units
  int max_points = 5000;                // --max-points: FPFH's cap (ClassicalRegistrationOptions)
  std::string icp_points = "occupied";  // --icp-points: "occupied" or "mask" (grid ICP)
  bool flips = true;                    // not --no-flips: grid ICP also from the 9 half-turns
  double icp_distance = GridRegistrationOptions::kDefaultIcpDistance;  // --icp-distance, in ICP voxels
  unsigned seed = 0;                                                   // --seed
  DregSolver dreg_solver = DregSolver::kProcrustes;                    // --dreg-solver
  int dreg_passes = 1;                                                 // --dreg-passes, 1..10
  bool block_icp = true;                                               // not --no-block-icp
  torch::Device device = torch::kCPU;  // --device: where the caller puts the blocks' fields and the network
  // --splat-density-scale, --splat-blur: how a splat PLY input becomes a density field.
  SplatFieldOptions splats;

  bool UsesNetwork() const { return method == RegistrationMethod::kAuto || method == RegistrationMethod::kDreg; }
  // Throws InputError naming the flag ("--field-iterations: expected >= 0").
  void Check() const;
  Json ToJson() const;
  // Reads what ToJson writes; `file` names the source in errors (InputError).
  static BlockRegistrationOptions FromJson(const Json& json, const std::string& file);
};

// How well two density fields agree at a pose, on one fixed sample set (FieldAgreementSamples).
// `confidence` is the soft Dice coefficient of the two occupancies o = 1 - exp(-scale * sigma)
// over every sample: 2 sum(a b) / sum(a^2 + b^2), a the sample's occupancy in its own block, b the
// other block's at the sample moved there (0 where it falls outside the other block's box, which
// vouches for nothing there). In [0, 1]: 1 when the fields coincide (a block with itself at the
// identity), near 0 when occupied samples land in empty space. docs/registration.md.
struct FieldAgreement {
  double confidence = 0;
  double cost = 0;             // mean (a - b)^2 over the samples inside the other box (AlignFields' cost)
  double inside_fraction = 0;  // share of samples inside the other block's box
  int samples = 0;             // samples in all
};

// The common samples: a band across each block's surface (its occupied points, each with two
// Gaussian offsets of 0.25 and 0.5 x `spread`), at most max_samples per block, drawn once with
// `seed`; source samples in the source frame, target samples in the target frame.
struct FieldAgreementSamples {
  Eigen::Matrix3Xd source;  // [3, Ns]
  Eigen::Matrix3Xd target;  // [3, Nt]
};
FieldAgreementSamples DrawFieldAgreementSamples(const Eigen::Matrix3Xd& source_points,
                                                const Eigen::Matrix3Xd& target_points, double spread, int max_samples,
                                                unsigned seed);

FieldAgreement ScoreFieldAgreement(const DensityField& source, const DensityField& target,
                                   const FieldAgreementSamples& samples, const Sim3d& target_from_source,
                                   double occupancy_scale);

// auto's choice: every pose scored on the same samples; the index of the highest confidence (the
// first on ties). `scores` (optional) gets each pose's agreement. Throws std::invalid_argument on
// no poses.
size_t ChooseCandidate(const DensityField& source, const DensityField& target, const FieldAgreementSamples& samples,
                       const std::vector<Sim3d>& target_from_source, double occupancy_scale,
                       std::vector<FieldAgreement>* scores = nullptr);

// One method's answer, refined.
struct RegistrationCandidate {
  std::string method;  // e.g. "dreg+icp+block+field": the method and its refinements
  Sim3d target_from_source;
  double method_score = 0;      // the method's own score: the network's confidence or the FPFH fitness
  FieldAgreement agreement;     // on the common samples (ScoreFieldAgreement)
  Json field;                   // the field refinement's record (null without kField)
  Json extra = Json::object();  // method details written into T.json (seconds, points, half_turn, block_icp)
  Eigen::Matrix3Xd source_points, target_points;  // [3, N]: what it registered (the overlays)
};

struct RegistrationResult {
  Sim3d target_from_source;
  std::string method;     // the kept candidate's
  double confidence = 0;  // the kept candidate's agreement.confidence
  std::vector<RegistrationCandidate> candidates;
  size_t chosen = 0;  // index into candidates
  // With several field-refined candidates: how many others ended within 2 deg and a grid cell of
  // the kept pose; -1 when not checked.
  int agreeing_candidates = -1;
  Json fallback;  // auto without kField: the dreg answer dropped for ransac (null: none)
  std::vector<std::string> warnings;
  double seconds = 0;
  BlockRegistrationOptions options;
  std::string source_kind = "nerf", target_kind = "nerf";  // RegistrationInput::Kind()

  const RegistrationCandidate& Chosen() const { return candidates.at(chosen); }
  // T.json: target_from_source, scale, method, confidence, method_score, field, not_chosen,
  // agreeing_candidates, fallback_from, seconds, warnings, the kept candidate's details
  // (block_icp, half_turn, ...) and "options".
  Json ToJson() const;
};

// `net`: needed when options.UsesNetwork() (std::invalid_argument when null). Checks `options`.
// The network for dreg / auto: the weights must exist (InputError naming them, or --weights) and,
// with options.config, be of that config.
DregNet LoadCheckedDregNet(const BlockRegistrationOptions& options);

// Before / after pictures of a registration beside `out` (OUT_before.png, OUT_after.png): the
// chosen candidate's source points in orange, target in blue, from three fixed viewpoints.
void WriteRegistrationOverlays(const std::string& out, const RegistrationResult& result);

// Any two inputs: NeRF blocks, splat sets, or one of each (reg/registration_input.h).
RegistrationResult RegisterBlocks(RegistrationInput& source, RegistrationInput& target,
                                  const BlockRegistrationOptions& options, DregNet* net);
RegistrationResult RegisterBlocks(NerfBlock& source, NerfBlock& target, const BlockRegistrationOptions& options,
                                  DregNet* net);

// Pieces the other jobs (reg eval --pairs, register-many) share.

// ICP on the blocks' occupied points (`src`, `tgt`: [3, N]) from `target_from_source`, after ICP
// on the grids: point-to-plane at `voxel`, correspondences within 2 voxels. `json` records it.
Sim3d RefineOnBlockPoints(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Sim3d& target_from_source,
                          double voxel, Json* json);

// The pose refined on the blocks' density fields (AlignFields, samples around `src_points` /
// `tgt_points`, spread `spread`); `json` records it. With both grids, each field's `seen` is set
// from its grid (FieldAlignmentOptions::overlap_only).
Sim3d RefineOnFields(NerfBlock& source, NerfBlock& target, const Eigen::Matrix3Xd& src_points,
                     const Eigen::Matrix3Xd& tgt_points, const Sim3d& target_from_source, FieldAlignmentOptions options,
                     double spread, Json* json, const RegGrid* src_grid = nullptr, const RegGrid* tgt_grid = nullptr);
// The same on any two density fields (RegistrationInput::Field).
Sim3d RefineOnFields(const DensityField& source, const DensityField& target, const Eigen::Matrix3Xd& src_points,
                     const Eigen::Matrix3Xd& tgt_points, const Sim3d& target_from_source, FieldAlignmentOptions options,
                     double spread, Json* json);

// A pair of inputs' occupied points (RegistrationInput::OccupiedPoints), extracted on first use.
class OccupiedPoints {
 public:
  OccupiedPoints(RegistrationInput& source, RegistrationInput& target, double min_density, unsigned seed)
      : source_(&source), target_(&target), min_density_(min_density), seed_(seed) {}
  OccupiedPoints(NerfBlock& source, NerfBlock& target, double min_density, unsigned seed)
      : owned_source_(std::make_unique<NerfBlockInput>(source)),
        owned_target_(std::make_unique<NerfBlockInput>(target)),
        source_(owned_source_.get()),
        target_(owned_target_.get()),
        min_density_(min_density),
        seed_(seed) {}
  const Eigen::Matrix3Xd& Source();  // [3, N]
  const Eigen::Matrix3Xd& Target();  // [3, M]
  double Seconds() const { return seconds_; }

 private:
  void Extract();
  std::unique_ptr<NerfBlockInput> owned_source_, owned_target_;
  RegistrationInput* source_;
  RegistrationInput* target_;
  double min_density_;
  unsigned seed_;
  bool done_ = false;
  double seconds_ = 0;
  Eigen::Matrix3Xd src_, tgt_;
};

}  // namespace nerfreg
