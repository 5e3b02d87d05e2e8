#pragma once
// What a registration of two inputs is asked to do: the methods as enums (their command-line and
// T.json spellings are parsed and printed here only) and BlockRegistrationOptions, the options of
// the whole chain (registration/register_pair.h), as `reg register` sets them and T.json records
// them.
#include <torch/torch.h>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/reg/splat_field.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// The coarse method. kAuto: dreg and FPFH + RANSAC (on the grids and the occupied points), the
// candidate whose fields agree best kept (with kField; else dreg, falling back to ransac).
enum class RegistrationMethod { kAuto, kDreg, kRansac, kFgr };
// kIcp: ICP on the grids, then on the blocks' occupied points; kField: then the fields aligned.
enum class RegistrationRefinement { kNone, kIcp, kField };
// dreg's pose from its correspondences: weighted Kabsch over all (the paper's), or RANSAC.
enum class DregSolver { kProcrustes, kRansac };
// kFree: the inputs' units may differ. Each input is brought to a common size by its own occupied
// extent before any method sees it (ScaleNormalization, registration/scale_normalization.h), and
// the point stages estimate a scale too (RANSAC and ICP with scaling); the result is a Sim(3).
// kFixed: both inputs in their own units, rigid stages only (the result's scale is 1).
enum class ScaleMode { kFree, kFixed };
// The points ICP on the grids aligns: every voxel over the density threshold, or the surface mask
// the network and the features see (GridRegistrationOptions::icp_points).
enum class IcpPoints { kOccupied, kMask };

// Names as the command line and T.json spell them ("auto", "dreg", ...). The *FromName functions
// throw InputError naming `option` ("--method: expected auto, dreg, ransac or fgr, got icp").
std::string RegistrationMethodName(RegistrationMethod method);
std::string RegistrationRefinementName(RegistrationRefinement refinement);
std::string DregSolverName(DregSolver solver);
std::string IcpPointsName(IcpPoints points);
std::string ScaleModeName(ScaleMode mode);
RegistrationMethod RegistrationMethodFromName(const std::string& name, const std::string& option = "--method");
RegistrationRefinement RegistrationRefinementFromName(const std::string& name, const std::string& option = "--refine");
DregSolver DregSolverFromName(const std::string& name, const std::string& option = "--dreg-solver");
IcpPoints IcpPointsFromName(const std::string& name, const std::string& option = "--icp-points");
ScaleMode ScaleModeFromName(const std::string& name, const std::string& option = "--scale");

// An enum's spellings, in the order an error lists them: Name and FromName for any enum (the
// functions above, and the other jobs' own lists such as reg eval's methods).
template <typename E>
struct EnumNames {
  std::vector<std::pair<E, std::string>> names;
  std::string Name(E e) const {
    for (const auto& [k, v] : names)
      if (k == e) return v;
    throw std::logic_error("unnamed registration enum value");
  }
  E FromName(const std::string& name, const std::string& option) const {
    std::string expected;
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i].second == name) return names[i].first;
      expected += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i].second;
    }
    ThrowInputError(option, "", expected + ", got " + name);
  }
};

// ICP's correspondence distance on the grids, in ICP voxels. Shorter fixes a converged pose more
// tightly but narrows the basin the network's pose must land in, and on the held-out real pairs
// the narrower basin cost more registrations than the tighter fit gained
// (docs/notes/2026-11-23-grids-icp-half-turn.md, "ICP correspondence distance").
inline constexpr double kDefaultIcpDistance = 2.0;

// Everything `reg register`'s options set (and `reg register-many`'s for each pair); reg eval
// --pairs fills the fields it uses and leaves the rest at these defaults. Each field names its flag.
struct BlockRegistrationOptions {
  RegistrationMethod method = RegistrationMethod::kRansac;         // --method
  RegistrationRefinement refine = RegistrationRefinement::kField;  // --refine
  // --scale. The job without inputs to normalise (reg eval --pairs on grids) sets kFixed.
  ScaleMode scale = ScaleMode::kFree;
  // --min-confidence: auto without kField falls back to ransac when the network's own score is
  // below this.
  double min_confidence = 0.3;
  // --field-iterations, --field-occupancy-scale, --field-samples (the rest at their defaults;
  // sample_spread is set to the grid's cell).
  FieldAlignmentOptions field;
  // --grid-resolution (dreg, auto: a multiple of 16, the backbone halves it four times).
  GridExtractionOptions grid;
  std::string weights;                               // --weights: recorded only; the caller loads the network
  std::string config;                                // --config: "", "cpu" or "paper" (recorded; checked by the caller)
  double min_density = 5.0;                          // --min-density: the occupied points' density threshold
  double voxel = 0.05;                               // --voxel: downsampling voxel, scene units
  int max_points = 5000;                             // --max-points: FPFH's cap (ClassicalRegistrationOptions)
  IcpPoints icp_points = IcpPoints::kOccupied;       // --icp-points (grid ICP)
  bool flips = true;                                 // not --no-flips: grid ICP also from the 9 half-turns
  double icp_distance = kDefaultIcpDistance;         // --icp-distance, in ICP voxels
  unsigned seed = 0;                                 // --seed
  DregSolver dreg_solver = DregSolver::kProcrustes;  // --dreg-solver
  int dreg_passes = 1;                               // --dreg-passes, 1..10
  bool block_icp = true;                             // not --no-block-icp
  bool check_turns = true;  // the turn check with kField (register_blocks.h, kTurnSwitchMargin)
  // not --no-reverse: an untrusted result is registered the other way too (register_blocks.h,
  // RegisterEitherWay).
  bool reverse_untrusted = true;
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

}  // namespace nerfreg
