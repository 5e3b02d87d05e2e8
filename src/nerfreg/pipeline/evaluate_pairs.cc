#include "nerfreg/pipeline/evaluate_pairs.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "nerfreg/data/ground_truth.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/reg/registration_input.h"
#include "nerfreg/reg/registration_success.h"
#include "nerfreg/registration/grid_registration.h"
#include "nerfreg/registration/register_blocks.h"
#include "nerfreg/registration/registration_chain.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/stats.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace {

const EnumNames<PairMethod> kPairMethodNames{{{PairMethod::kDreg, "dreg"},
                                              {PairMethod::kRansac, "ransac"},
                                              {PairMethod::kFgr, "fgr"},
                                              {PairMethod::kTruth, "truth"},
                                              {PairMethod::kAuto, "auto"}}};
const EnumNames<PairRefinement> kPairRefinementNames{{{PairRefinement::kNone, "none"},
                                                      {PairRefinement::kIcp, "icp"},
                                                      {PairRefinement::kBlockIcp, "block-icp"},
                                                      {PairRefinement::kField, "field"}}};

RegistrationMethod MethodOf(PairMethod m) {
  return m == PairMethod::kDreg  ? RegistrationMethod::kDreg
         : m == PairMethod::kFgr ? RegistrationMethod::kFgr
                                 : RegistrationMethod::kRansac;
}

bool NeedsBlocks(PairRefinement r) { return r == PairRefinement::kBlockIcp || r == PairRefinement::kField; }

// The chain's options for one row.
BlockRegistrationOptions RowOptions(const PairEvaluationOptions& options, DregSolver solver, int passes,
                                    PairRefinement refine) {
  BlockRegistrationOptions o = options.base;
  // The rows run the chain on grids or blocks that share a unit: rigid.
  o.scale = ScaleMode::kFixed;
  o.dreg_solver = solver;
  o.dreg_passes = passes;
  o.refine = refine == PairRefinement::kNone    ? RegistrationRefinement::kNone
             : refine == PairRefinement::kField ? RegistrationRefinement::kField
                                                : RegistrationRefinement::kIcp;
  o.block_icp = NeedsBlocks(refine);
  return o;
}

// The refinement floor's start: the ground truth, refined by ICP on the grids (without its
// half-turns) unless refine is kNone.
RegistrationResult TruthStart(RegistrationPair& pair, const Eigen::Matrix4d& truth, const BlockRegistrationOptions& o) {
  Timer timer;
  RegistrationResult r;
  r.method = "truth";
  r.target_from_source = Sim3d::FromMatrix(truth, 1e-3);
  r.method_score = 1;
  r.cloud = RegistrationCloud::kGridMask;
  if (o.refine != RegistrationRefinement::kNone) {
    GridRegistrationOptions g = GridOptionsFor(o, RegistrationMethod::kRansac);
    const std::string name = g.Name();  // "ransac+icp[mask]...": the ICP's part names the row
    g.flips = false;                    // no half-turns of the truth
    r.target_from_source = RefineGridPose(pair.SourceGrid(), pair.TargetGrid(), r.target_from_source, g);
    r.method = "truth" + name.substr(name.find("+icp"));
  }
  r.seconds = timer.Seconds();
  return r;
}

}  // namespace

std::string PairMethodName(PairMethod m) { return kPairMethodNames.Name(m); }
std::string PairRefinementName(PairRefinement r) { return kPairRefinementNames.Name(r); }
PairMethod PairMethodFromName(const std::string& name, const std::string& option) {
  return kPairMethodNames.FromName(name, option);
}
PairRefinement PairRefinementFromName(const std::string& name, const std::string& option) {
  return kPairRefinementNames.FromName(name, option);
}

void PairEvaluationOptions::Check() const {
  for (const int passes : dreg_passes)
    if (passes < 1 || passes > 10) ThrowInputError("--dreg-passes", "", "1..10");
  if (!(base.voxel > 0)) ThrowInputError("--voxel", "", "> 0");
  if (!(base.icp_distance > 0)) ThrowInputError("--icp-distance", "", "> 0 (ICP voxels)");
}

std::vector<PairEvaluation> EvaluatePairs(const std::vector<PairRecord>& pairs, const PairEvaluationOptions& options,
                                          DregNet* net, const std::function<void(const PairEvaluation&)>& on_row) {
  options.Check();
  std::vector<PairEvaluation> rows;
  bool warned_field = false;
  for (const auto& p : pairs) {
    // --refine block-icp and field need the blocks themselves: real pairs keep block_K.ckpt beside
    // block_K.grid.
    std::unique_ptr<RegistrationInput> src_block, tgt_block;
    const bool auto_rows =
        std::find(options.methods.begin(), options.methods.end(), PairMethod::kAuto) != options.methods.end();
    for (const PairRefinement rf : options.refines) {
      if (!(NeedsBlocks(rf) || auto_rows) || src_block) continue;
      if (p.kind != "nerf") {
        if (!warned_field) {
          LOG_WARN("--refine {} / --methods auto: skipped on synthesised pairs (no NeRF blocks), e.g. {}",
                   PairRefinementName(rf), p.name);
        }
        warned_field = true;
        continue;
      }
      auto ckpt = [](const std::string& grid) {
        return grid.substr(0, grid.size() - std::string(".grid").size()) + ".ckpt";
      };
      src_block = std::make_unique<NerfBlockInput>(LoadNerfBlock(ckpt(p.source), nullptr, options.device));
      tgt_block = std::make_unique<NerfBlockInput>(LoadNerfBlock(ckpt(p.target), nullptr, options.device));
    }
    RegistrationPair pair(LoadRegGrid(p.source), LoadRegGrid(p.target), src_block.get(), tgt_block.get(), options.base);
    const Sim3d truth = Sim3d::FromMatrix(p.target_from_source, 1e-3);
    for (const PairMethod m : options.methods) {
      const bool dreg = m == PairMethod::kDreg;
      for (const DregSolver solver : dreg ? options.dreg_solvers : std::vector<DregSolver>{DregSolver::kRansac})
        for (const int passes : dreg ? options.dreg_passes : std::vector<int>{1})
          for (const PairRefinement rf : options.refines) {
            if ((NeedsBlocks(rf) || m == PairMethod::kAuto) && !pair.HasInputs()) continue;
            PairEvaluation row;
            RegistrationResult r;
            if (m == PairMethod::kAuto) {
              // reg register itself on the blocks: `method` names the row, `kept` the candidate.
              BlockRegistrationOptions o = RowOptions(options, options.base.dreg_solver, 1, rf);
              o.method = RegistrationMethod::kAuto;
              o.scale = options.base.scale;
              const BlockRegistrationResult b = RegisterBlocks(*src_block, *tgt_block, o, net);
              r.target_from_source = b.target_from_source;
              r.method = "auto+" + PairRefinementName(rf);
              r.seconds = b.seconds;
              r.method_score = b.confidence;
              row.kept = b.method;
              row.status = b.status;
            } else {
              // reg register's chain: the method on the grids, then as far as `rf` asks.
              const BlockRegistrationOptions o = RowOptions(options, solver, passes, rf);
              r = m == PairMethod::kTruth ? TruthStart(pair, p.target_from_source, o)
                                          : RegisterCoarse(pair, MethodOf(m), RegistrationCloud::kGridMask, o, net);
              ContinueChain(pair, o, &r);
            }
            row.pair = p.name;
            row.method = r.method;
            row.seconds = r.seconds;
            row.confidence = r.method_score;
            row.overlap = p.overlap;
            row.rotation_deg = RotationErrorDeg(r.target_from_source.rotation, truth.rotation);
            row.translation = TranslationError(r.target_from_source.translation, truth.translation);
            rows.push_back(row);
            if (on_row) on_row(row);
          }
    }
  }
  return rows;
}

namespace {

// printf into a string.
void Appendf(std::string* out, const char* format, ...) {
  va_list args, copy;
  va_start(args, format);
  va_copy(copy, args);
  const int n = std::vsnprintf(nullptr, 0, format, copy);
  va_end(copy);
  if (n > 0) {
    std::string s(static_cast<size_t>(n) + 1, '\0');
    std::vsnprintf(s.data(), s.size(), format, args);
    s.pop_back();
    *out += s;
  }
  va_end(args);
}

}  // namespace

PairSummary SummarisePairEvaluations(const std::vector<PairEvaluation>& rows, double overlap_threshold) {
  PairSummary out;
  Json& summary = out.json;
  std::string& table = out.table;
  Appendf(&table, "\n%-20s %6s %10s %10s %12s %10s %10s %9s\n", "method", "pairs", "mean rot", "med rot",
          "med trans/ext", "succ 5/.05", "succ 10/.1", "med time");
  std::vector<std::string> names;
  for (const auto& r : rows)
    if (std::find(names.begin(), names.end(), r.method) == names.end()) names.push_back(r.method);
  auto success = [](const PairEvaluation& r, double deg, double fraction) {
    return RegistrationSucceeded(r.rotation_deg, r.translation, deg, fraction);
  };
  for (const auto& name : names) {
    std::vector<double> rot, trans, secs;
    int s5 = 0, s10 = 0;
    for (const auto& r : rows) {
      if (r.method != name) continue;
      rot.push_back(r.rotation_deg);
      trans.push_back(r.translation / kObjectExtent);
      secs.push_back(r.seconds);
      s5 += success(r, 5, 0.05);
      s10 += success(r, 10, 0.1);
    }
    double mean = 0;
    for (double x : rot) mean += x / rot.size();
    const double n = static_cast<double>(rot.size());
    summary[name] = {{"pairs", rot.size()},
                     {"mean_rotation_deg", mean},
                     {"median_rotation_deg", Median(rot)},
                     {"median_translation_fraction", Median(trans)},
                     {"success_5deg_0.05", s5 / n},
                     {"success_10deg_0.1", s10 / n},
                     {"median_seconds", Median(secs)}};
    Appendf(&table, "%-20s %6zu %10.3f %10.3f %12.4f %9.0f%% %9.0f%% %9.2f\n", name.c_str(), rot.size(), mean,
            Median(rot), Median(trans), 100 * s5 / n, 100 * s10 / n, Median(secs));
  }
  // Success by overlap: a set that mixes pair overlaps (the 4-block splits: 0.49-0.96) hides in one
  // rate whether a method fails only the low-overlap pairs, the case a learned registrar must win.
  const bool mixed =
      std::any_of(rows.begin(), rows.end(), [&](const PairEvaluation& r) { return r.overlap < overlap_threshold; }) &&
      std::any_of(rows.begin(), rows.end(), [&](const PairEvaluation& r) { return r.overlap >= overlap_threshold; });
  if (mixed) {
    char below[32], above[32];
    std::snprintf(below, sizeof below, "overlap < %.2f", overlap_threshold);
    std::snprintf(above, sizeof above, "overlap >= %.2f", overlap_threshold);
    Appendf(&table, "\n%-20s %16s %16s   (successes at 5 deg / 0.05 by the pair's overlap)\n", "method", below, above);
  }
  for (const auto& name : names) {
    int n_low = 0, ok_low = 0, n_high = 0, ok_high = 0;
    for (const auto& r : rows) {
      if (r.method != name) continue;
      const bool ok = success(r, 5, 0.05);
      (r.overlap < overlap_threshold ? n_low : n_high) += 1;
      (r.overlap < overlap_threshold ? ok_low : ok_high) += ok;
    }
    summary[name]["by_overlap"] = {{"threshold", overlap_threshold},
                                   {"below", {{"pairs", n_low}, {"successes_5deg_0.05", ok_low}}},
                                   {"at_or_above", {{"pairs", n_high}, {"successes_5deg_0.05", ok_high}}}};
    if (mixed)
      Appendf(&table, "%-20s %16s %16s\n", name.c_str(),
              (std::to_string(ok_low) + " of " + std::to_string(n_low)).c_str(),
              (std::to_string(ok_high) + " of " + std::to_string(n_high)).c_str());
  }
  return out;
}

PairsFileEvaluation EvaluatePairsFile(const PairsFileEvaluationOptions& o, const std::function<void()>& on_start,
                                      const std::function<void(const PairEvaluation&)>& on_row) {
  std::vector<PairRecord> pairs;
  for (const auto& p : ReadPairs(o.pairs_path))
    if (o.split == "all" || p.split == o.split) pairs.push_back(p);
  if (o.max_pairs > 0 && static_cast<int>(pairs.size()) > o.max_pairs) pairs.resize(o.max_pairs);
  if (pairs.empty()) ThrowInputError(o.pairs_path, "pairs", "at least one pair of split " + o.split);
  std::unique_ptr<DregNet> net;
  for (const auto& m : o.evaluation.methods) {
    if ((m == PairMethod::kDreg || m == PairMethod::kAuto) && !net) {
      if (!FileExists(o.weights)) ThrowInputError(o.weights, "", "DReg-NeRF weights (reg train) for --methods dreg");
      DregModelOptions mo;
      net = std::make_unique<DregNet>(LoadDregWeights(o.weights, &mo));
      (*net)->to(o.evaluation.device);
    }
  }
  if (on_start) on_start();
  PairsFileEvaluation result;
  result.rows = EvaluatePairs(pairs, o.evaluation, net.get(), on_row);
  result.summary = SummarisePairEvaluations(result.rows, o.overlap_threshold);
  if (!o.out.empty()) {
    Json table = Json::array();
    for (const auto& r : result.rows) {
      table.push_back({{"pair", r.pair},
                       {"method", r.method},
                       {"rotation_error_deg", r.rotation_deg},
                       {"translation_error", r.translation},
                       {"translation_error_fraction", r.translation / kObjectExtent},
                       {"confidence", r.confidence},
                       {"overlap", r.overlap},
                       {"seconds", r.seconds}});
      if (!r.kept.empty()) table.back()["kept"] = r.kept, table.back()["status"] = r.status;
    }
    WriteJsonFile(
        o.out, {{"pairs_file", o.pairs_path}, {"split", o.split}, {"rows", table}, {"summary", result.summary.json}});
  }
  return result;
}

RegistrationError EvaluateRegistrationFile(const std::string& pair, const std::string& gt_path, int source, int target,
                                           const std::string& out) {
  const Json pj = ReadJsonFile(pair);
  const GroundTruthFile truth(gt_path);
  const JsonField p(pj, pair);
  Sim3d est, gt, swapped;
  try {
    est = Sim3d::FromMatrix(p["target_from_source"].Matrix(4, 4));
    gt = truth.TargetFromSource(source, target);
    swapped = truth.TargetFromSource(target, source);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("reg eval: a transform is not a similarity: ") + e.what());
  }
  RegistrationError r;
  r.rotation_deg = RotationErrorDeg(est.rotation, gt.rotation);
  r.translation = TranslationError(est.translation, gt.translation);
  r.translation_fraction = r.translation / kObjectExtent;
  r.success = RegistrationSucceeded(r.rotation_deg, r.translation);
  r.scale = est.scale;
  r.true_scale = gt.scale;
  r.scale_error = std::abs(est.scale / gt.scale - 1);
  const double swapped_rotation_deg = RotationErrorDeg(est.rotation, swapped.rotation);
  r.matches_swapped =
      source != target && !r.success &&
      RegistrationSucceeded(swapped_rotation_deg, TranslationError(est.translation, swapped.translation));
  r.method = p.StringOr("method", "?");
  if (r.matches_swapped) {
    LOG_WARN(
        "{}: the result matches block {} -> {} ({:.2f} deg), not {} -> {} ({:.2f} deg): was it registered the "
        "other way (--source {} --target {})?",
        pair, target, source, swapped_rotation_deg, source, target, r.rotation_deg, target, source);
  }
  r.json = {{"rotation_error_deg", r.rotation_deg},
            {"translation_error", r.translation},
            {"translation_error_fraction", r.translation_fraction},
            {"success", r.success},
            {"scale", r.scale},
            {"true_scale", r.true_scale},
            {"scale_error", r.scale_error},
            {"matches_swapped", r.matches_swapped},
            {"method", r.method},
            {"seconds", p.DoubleOr("seconds", 0)}};
  if (!out.empty()) WriteJsonFile(out, r.json);
  return r;
}

}  // namespace nerfreg
