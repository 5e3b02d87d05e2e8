// reg eval: a registration scored against the ground truth, or every method on a pairs file.
#include <fmt/format.h>

#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/pipeline/evaluate_pairs.h"
#include "nerfreg/registration/registration_options.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

namespace {

// `reg eval --pairs`: every method on every pair's grids, one table.
int EvalPairs(const PairsFileEvaluationOptions& o) {
  const auto header = [] {
    std::printf("%-32s %-20s %8s %10s %10s %8s %8s\n", "pair", "method", "overlap", "rot (deg)", "trans/ext", "conf",
                "time (s)");
  };
  const PairsFileEvaluation r = EvaluatePairsFile(o, header, [](const PairEvaluation& row) {
    std::printf("%-32s %-20s %8.2f %10.3f %10.4f %8.2f %8.2f\n", row.pair.c_str(), row.method.c_str(), row.overlap,
                row.rotation_deg, row.translation / kObjectExtent, row.confidence, row.seconds);
    std::fflush(stdout);
  });
  std::printf("%s", r.summary.table.c_str());
  return 0;
}

// `reg eval --pair`: one result against the ground truth.
int EvalPair(const std::string& pair, const std::string& gt_path, int source, int target, const std::string& out) {
  const RegistrationError r = EvaluateRegistrationFile(pair, gt_path, source, target, out);
  std::printf("%-22s %10s %12s %10s %8s\n", "method", "rot (deg)", "trans", "trans/ext", "success");
  std::printf("%-22s %10.3f %12.4f %10.4f %8s\n", r.method.c_str(), r.rotation_deg, r.translation,
              r.translation_fraction, r.success ? "yes" : "no");
  return 0;
}

}  // namespace

constexpr const char* kMethodsHelp =
    "With --pairs: dreg, ransac, fgr (comma separated), truth: each --refine started at the ground truth (after ICP "
    "on the grids, without half-turns, unless --refine none: where the chain ends from the truth), or auto: reg "
    "register itself on a real pair's blocks (normalised with --scale free, every candidate, the choice)";

int RunRegEval(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Registration errors against the ground truth: rotation (geodesic, degrees) and translation (full "
      "norm, also as a fraction of the object extent 2.5). Either one result (--pair + --ground-truth) or a "
      "table of every method on every pair of a reg make-data folder (--pairs), with mean, median and "
      "success rates at 5 deg / 0.05 and 10 deg / 0.1.",
      "nerfreg reg eval --pairs data/reg_val/pairs.json --methods dreg,ransac,fgr --refine none,icp");
  std::string pair, gt_path, out, pairs_path, split = "val", weights = DefaultDregWeights(), device = "cpu";
  AddDeviceOption(app, &device);
  std::vector<std::string> methods = {"ransac"}, refines = {"icp"}, dreg_solvers = {"procrustes"};
  std::vector<int> dreg_passes = {1};
  int source = 0, target = 1, max_pairs = 0;
  double voxel = 0.05, overlap_threshold = 0.8;
  app.add_option("--pair", pair, "Registration output (reg register)");
  app.add_option("--ground-truth", gt_path, "ground_truth.json of the rendered dataset");
  app.add_option("--source", source, "Source block index (default 0)");
  app.add_option("--target", target, "Target block index (default 1)");
  app.add_option("--pairs", pairs_path, "pairs.json of reg make-data: evaluate every method on its pairs");
  app.add_option("--methods", methods, kMethodsHelp)->delimiter(',');
  app.add_option("--refine", refines,
                 "With --pairs: none, icp (on the grids), block-icp (ICP on the grids, then on the blocks' occupied "
                 "points, as reg register; real NeRF pairs only), field (block-icp, then the density fields aligned; "
                 "real NeRF pairs only), comma separated")
      ->delimiter(',');
  app.add_option("--dreg-solver", dreg_solvers,
                 "With --pairs: dreg's pose by ransac, procrustes or both (comma separated)")
      ->delimiter(',');
  app.add_option("--dreg-passes", dreg_passes,
                 "With --pairs: dreg's network passes, e.g. 1,2 (comma separated; default 1)")
      ->delimiter(',')
      ->check(CLI::Range(1, 10));
  app.add_option("--split", split, "With --pairs: the pairs of this split (train, val or all; default val)");
  app.add_option("--max-pairs", max_pairs, "With --pairs: at most this many pairs");
  app.add_option("--overlap-threshold", overlap_threshold,
                 "With --pairs: success is also counted apart below and above this pair overlap (default 0.8)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--weights", weights, "DReg-NeRF weights for --methods dreg");
  app.add_option("--voxel", voxel, "Classical downsampling voxel (default 0.05)");
  PairEvaluationOptions eo;
  app.add_flag("--field-overlap-only", eo.base.field.overlap_only,
               "With --refine field: count only samples where the other block's cameras saw the surface (its grid's "
               "mask; an experiment: no gain on the held-out real pairs, "
               "docs/notes/2026-11-24-experiments-not-kept.md)");
  std::string icp_points = "occupied", scale = "free";
  bool no_flips = false;
  AddIcpOptions(app, &icp_points, &no_flips, &eo.base.icp_distance);
  app.add_option("--scale", scale,
                 "With --methods auto: free (default, as reg register) or fixed; the other methods run rigid on grids "
                 "that share a unit")
      ->check(CLI::IsMember({"free", "fixed"}));
  app.add_option("--out", out, "Also write the errors to this JSON file");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const torch::Device dev = ParseDevice(device);
  if (!out.empty()) CheckCanWriteOutput(out, common.force, {pair, gt_path, pairs_path, weights});
  if (!pairs_path.empty()) {
    eo.base.voxel = voxel;
    eo.base.flips = !no_flips;
    eo.base.icp_points = IcpPointsFromName(icp_points);
    eo.base.scale = ScaleModeFromName(scale);
    eo.methods.clear(), eo.refines.clear(), eo.dreg_solvers.clear();
    for (const auto& m : methods) eo.methods.push_back(PairMethodFromName(m));
    for (const auto& r : refines) eo.refines.push_back(PairRefinementFromName(r));
    for (const auto& d : dreg_solvers) eo.dreg_solvers.push_back(DregSolverFromName(d));
    eo.dreg_passes = dreg_passes;
    eo.device = dev;
    eo.Check();
    return EvalPairs({pairs_path, split, weights, out, max_pairs, overlap_threshold, eo});
  }
  if (pair.empty() || gt_path.empty())
    ThrowInputError("reg eval", "", "--pairs FILE, or --pair FILE with --ground-truth FILE");
  return EvalPair(pair, gt_path, source, target, out);
}
