// Commands of the registration layer: reg register | reg eval.
#include <fmt/format.h>

#include <cmath>

#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/pipeline/evaluate_pairs.h"
#include "nerfreg/pipeline/register_blocks.h"
#include "nerfreg/pipeline/register_many_blocks.h"
#include "nerfreg/posegraph/pose_graph.h"
#include "nerfreg/reg/baselines.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/reg/register_grids.h"
#include "nerfreg/reg/training_data.h"
#include "nerfreg/render/point_splat.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

namespace {

// Before / after: source in orange, target in blue, from three fixed viewpoints, beside `out`.
void WriteOverlays(const std::string& out, const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt,
                   const Sim3d& target_from_source) {
  const std::string stem = out.substr(0, out.size() - LowerExtension(out).size());
  auto subsample = [](const Eigen::Matrix3Xd& m) {
    const Eigen::Index step = std::max<Eigen::Index>(1, m.cols() / 20000);
    Eigen::Matrix3Xd s(3, (m.cols() + step - 1) / step);
    for (Eigen::Index i = 0, k = 0; i < m.cols(); i += step, ++k) s.col(k) = m.col(i);
    return s;
  };
  const Eigen::Matrix3Xd s_small = subsample(src), t_small = subsample(tgt);
  Eigen::Matrix3Xd moved(3, s_small.cols());
  for (Eigen::Index i = 0; i < s_small.cols(); ++i) moved.col(i) = target_from_source * Eigen::Vector3d(s_small.col(i));
  const Eigen::Vector3d centre = t_small.cols() ? Eigen::Vector3d(t_small.rowwise().mean()) : Eigen::Vector3d::Zero();
  const Eigen::Vector3f orange(0.95f, 0.5f, 0.1f), blue(0.1f, 0.35f, 0.9f);
  WriteImage(stem + "_before.png", ThreeViewOverlay({{s_small, orange}, {t_small, blue}}, centre, 5.0));
  WriteImage(stem + "_after.png", ThreeViewOverlay({{moved, orange}, {t_small, blue}}, centre, 5.0));
}

// Errors of an estimate against the truth (or between two estimates): geodesic rotation angle
// (deg) and the full norm of the translation difference (scene units).
void Errors(const Eigen::Matrix4d& est_m, const Eigen::Matrix4d& gt_m, double* rot, double* trans) {
  const Sim3d est = Sim3d::FromMatrix(est_m, 1e-3), gt = Sim3d::FromMatrix(gt_m, 1e-3);
  *rot = RotationErrorDeg(est.rotation, gt.rotation);
  *trans = TranslationError(est.translation, gt.translation);
}

// FPFH + RANSAC on the occupied points of a large block took 13 s (the milk truck: 16k points
// after downsampling); capped at 5000 it takes 2.7 s. The other held-out pairs (2.5-2.7k points)
// are under the cap.
void AddMaxPointsOption(CLI::App& app, int* max_points) {
  app.add_option("--max-points", *max_points,
                 "ransac / fgr on the occupied points: above this many points after downsampling, the features and "
                 "the global search use a coarser voxel (ICP stays at --voxel); 0: no cap (default 5000)")
      ->check(CLI::NonNegativeNumber);
}

// ICP on the grids: its points and the half-turn check (GridRegistrationOptions).
void AddIcpOptions(CLI::App& app, std::string* icp_points, bool* no_flips, double* icp_distance) {
  app.add_option("--icp-points", *icp_points,
                 "Grids: the points ICP aligns, occupied (every voxel over the density threshold; default) or mask "
                 "(the surface mask the network sees)")
      ->check(CLI::IsMember({"occupied", "mask"}));
  app.add_flag("--no-flips", *no_flips,
               "Grids: ICP from the pose alone, not also from its 9 half-turns (by default the one whose voxels agree "
               "best in place and colour is kept)");
  app.add_option("--icp-distance", *icp_distance,
                 "Grids: ICP's correspondence distance in ICP voxels (max(--voxel, 1.1 grid cells); default " +
                     fmt::format("{:g}", GridRegistrationOptions::kDefaultIcpDistance) + ")")
      ->check(CLI::PositiveNumber);
}

}  // namespace

// The shipped weights: NERFREG_WEIGHTS overrides; else models/dreg_cpu.pt of the source tree.
std::string DefaultDregWeights() {
  if (const char* env = std::getenv("NERFREG_WEIGHTS")) return env;
  return std::string(NERFREG_MODELS_DIR) + "/dreg_cpu.pt";
}

// auto (dreg, falling back to FPFH + RANSAC when its confidence is low) when weights are there,
// else FPFH + RANSAC.
std::string DefaultRegistrationMethod() { return FileExists(DefaultDregWeights()) ? "auto" : "ransac"; }

namespace {

// reg register's flags, as typed: the enums are parsed after CLI11 has checked the names.
struct RegisterFlags {
  std::string source, target, out, method = DefaultRegistrationMethod(), refine = "field", dreg_solver = "procrustes";
  bool no_flips = false, no_block_icp = false;
  std::string device = "cpu";
  BlockRegistrationOptions options;
};

void AddRegisterFlags(CLI::App& app, RegisterFlags* f) {
  BlockRegistrationOptions& o = f->options;
  o.weights = DefaultDregWeights();
  app.add_option("source", f->source, "Source block checkpoint")->required();
  app.add_option("target", f->target, "Target block checkpoint")->required();
  AddDeviceOption(app, &f->device);
  app.add_option("--out", f->out, "Output JSON")->required();
  app.add_option("--method", f->method,
                 "auto (default with weights: dreg and ransac, each refined, the one whose fields agree best on common "
                 "samples kept; without --refine field: dreg, then ransac when dreg's confidence < --min-confidence), "
                 "dreg, ransac or fgr")
      ->check(CLI::IsMember({"auto", "ransac", "fgr", "dreg"}));
  app.add_option("--min-confidence", o.min_confidence,
                 "auto without --refine field: dreg answers below this confidence fall back to ransac (0.3)");
  app.add_option("--refine", f->refine,
                 "none, icp (point-to-plane ICP; on the grids see --icp-points, --no-flips, then again on the blocks' "
                 "occupied points, see --no-block-icp) or field (ICP, then the two density fields aligned: finer than "
                 "the grid)")
      ->check(CLI::IsMember({"none", "icp", "field"}));
  app.add_option("--field-iterations", o.field.iterations, "field: Levenberg-Marquardt iterations at most (default 30)");
  app.add_option("--field-occupancy-scale", o.field.occupancy_scale,
                 "field: occupancy = 1 - exp(-scale * density) (default 0.05)");
  app.add_option("--field-samples", o.field.max_samples, "field: samples per block at most (default 6000)");
  app.add_option("--weights", o.weights, "DReg-NeRF weights (method dreg; default: the shipped models/dreg_cpu.pt)");
  app.add_option("--grid-resolution", o.grid.resolution,
                 "dreg: grid voxels per side (default 32, as the shipped weights were trained)");
  app.add_option("--config", o.config, "dreg: require weights of this network config (cpu or paper)")
      ->check(CLI::IsMember({"cpu", "paper"}));
  app.add_option("--min-density", o.min_density, "Density above which a cell's point is used (default 5)");
  app.add_option("--voxel", o.voxel, "Downsampling voxel, scene units (default 0.05)");
  AddMaxPointsOption(app, &o.max_points);
  AddIcpOptions(app, &o.icp_points, &f->no_flips, &o.icp_distance);
  app.add_option("--seed", o.seed, "Random seed");
  app.add_option("--dreg-solver", f->dreg_solver,
                 "dreg: pose from the network's correspondences by procrustes (default: the paper's weighted Kabsch "
                 "over all of them) or ransac (RANSAC over them, then Kabsch on its inliers)")
      ->check(CLI::IsMember({"ransac", "procrustes"}));
  app.add_option("--dreg-passes", o.dreg_passes,
                 "dreg: network passes; each after the first re-runs the network on the source moved by the pose so "
                 "far (default 1, as the paper)")
      ->check(CLI::Range(1, 10));
  app.add_flag("--no-block-icp", f->no_block_icp,
               "Grids (dreg, auto): ICP on the grids only, not again on the blocks' occupied points (by default it "
               "runs after ICP on the grids, before --refine field)");
}

// The network for dreg / auto: the weights must exist and, with --config, be of that config.
DregNet LoadCheckedDregNet(const BlockRegistrationOptions& o) {
  if (o.weights.empty() || !FileExists(o.weights)) {
    ThrowInputError(o.weights.empty() ? "--weights" : o.weights, "", "DReg-NeRF weights (reg train), or --method ransac / fgr");
  }
  DregModelOptions model_options;
  DregNet net = LoadDregWeights(o.weights, &model_options);
  if (!o.config.empty()) {
    CheckDregOptionsMatch(model_options, o.config == "paper" ? DregModelOptions::Paper() : DregModelOptions::Cpu(), o.weights);
  }
  net->to(o.device);
  return net;
}

}  // namespace

int RunRegRegister(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Register two NeRF blocks from their fields alone: target_from_source maps points of the source "
                  "block's frame into the target's. Methods: ransac (FPFH + RANSAC), fgr (FPFH + fast global "
                  "registration), dreg (the learned DReg-NeRF network; needs trained weights), auto (dreg and "
                  "ransac, the best on the fields kept). Refinement: icp (on the grids, then on the blocks' occupied "
                  "points), then by default field (the two density fields aligned). Writes T.json (with the options "
                  "used) and before/after overlay pictures beside it.",
                  "nerfreg reg register runs/block_0.ckpt runs/block_1.ckpt --out runs/target_from_source.json");
  RegisterFlags f;
  AddRegisterFlags(app, &f);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  BlockRegistrationOptions& o = f.options;
  o.device = ParseDevice(f.device);
  CheckCanWriteOutput(f.out, common.force, {f.source, f.target, o.weights});
  o.method = RegistrationMethodFromName(f.method);
  o.refine = RegistrationRefinementFromName(f.refine);
  o.dreg_solver = DregSolverFromName(f.dreg_solver);
  o.flips = !f.no_flips;
  o.block_icp = !f.no_block_icp;
  o.Check();
  Timer timer;
  NerfBlock source = LoadNerfBlock(f.source, nullptr, o.device), target = LoadNerfBlock(f.target, nullptr, o.device);
  std::unique_ptr<DregNet> net;
  if (o.UsesNetwork()) net = std::make_unique<DregNet>(LoadCheckedDregNet(o));
  RegistrationResult r = RegisterBlocks(source, target, o, net.get());
  r.seconds = timer.Seconds();  // T.json's seconds: the whole command, loading included
  const Json json = r.ToJson();
  WriteJsonFile(f.out, json);
  WriteOverlays(f.out, r.Chosen().source_points, r.Chosen().target_points, r.target_from_source);
  std::printf("%s\n", json.dump().c_str());
  return 0;
}

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// Prints the summary per method (mean, median, success at 5 deg / 0.05 and 10 deg / 0.1 of the
// extent, and by overlap when the pairs mix overlaps) and returns it.
Json SummariseRows(const std::vector<PairEvaluation>& rows, double overlap_threshold) {
  Json summary = Json::object();
  std::printf("\n%-20s %6s %10s %10s %12s %10s %10s %9s\n", "method", "pairs", "mean rot", "med rot", "med trans/ext",
              "succ 5/.05", "succ 10/.1", "med time");
  std::vector<std::string> names;
  for (const auto& r : rows)
    if (std::find(names.begin(), names.end(), r.method) == names.end()) names.push_back(r.method);
  auto success = [](const PairEvaluation& r, double deg, double fraction) {
    return r.rotation_deg <= deg && r.translation / 2.5 <= fraction;
  };
  for (const auto& name : names) {
    std::vector<double> rot, trans, secs;
    int s5 = 0, s10 = 0;
    for (const auto& r : rows) {
      if (r.method != name) continue;
      rot.push_back(r.rotation_deg);
      trans.push_back(r.translation / 2.5);
      secs.push_back(r.seconds);
      s5 += success(r, 5, 0.05);
      s10 += success(r, 10, 0.1);
    }
    double mean = 0;
    for (double x : rot) mean += x / rot.size();
    const double n = static_cast<double>(rot.size());
    summary[name] = {{"pairs", rot.size()}, {"mean_rotation_deg", mean}, {"median_rotation_deg", Median(rot)},
                     {"median_translation_fraction", Median(trans)}, {"success_5deg_0.05", s5 / n},
                     {"success_10deg_0.1", s10 / n}, {"median_seconds", Median(secs)}};
    std::printf("%-20s %6zu %10.3f %10.3f %12.4f %9.0f%% %9.0f%% %9.2f\n", name.c_str(), rot.size(), mean, Median(rot),
                Median(trans), 100 * s5 / n, 100 * s10 / n, Median(secs));
  }
  // Success by overlap: a set that mixes pair overlaps (the 4-block splits: 0.49-0.96) hides in one
  // rate whether a method fails only the low-overlap pairs, the case a learned registrar must win.
  const bool mixed = std::any_of(rows.begin(), rows.end(), [&](const PairEvaluation& r) { return r.overlap < overlap_threshold; }) &&
                     std::any_of(rows.begin(), rows.end(), [&](const PairEvaluation& r) { return r.overlap >= overlap_threshold; });
  if (mixed) {
    char below[32], above[32];
    std::snprintf(below, sizeof below, "overlap < %.2f", overlap_threshold);
    std::snprintf(above, sizeof above, "overlap >= %.2f", overlap_threshold);
    std::printf("\n%-20s %16s %16s   (successes at 5 deg / 0.05 by the pair's overlap)\n", "method", below, above);
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
      std::printf("%-20s %16s %16s\n", name.c_str(), (std::to_string(ok_low) + " of " + std::to_string(n_low)).c_str(),
                  (std::to_string(ok_high) + " of " + std::to_string(n_high)).c_str());
  }
  return summary;
}

// `reg eval --pairs`: every method on every pair's grids, one table.
int EvalPairs(const std::string& pairs_path, const PairEvaluationOptions& eo, const std::string& split, const std::string& weights,
              int max_pairs, double overlap_threshold, const std::string& out) {
  std::vector<PairRecord> pairs;
  for (const auto& p : ReadPairs(pairs_path))
    if (split == "all" || p.split == split) pairs.push_back(p);
  if (max_pairs > 0 && static_cast<int>(pairs.size()) > max_pairs) pairs.resize(max_pairs);
  if (pairs.empty()) ThrowInputError(pairs_path, "pairs", "at least one pair of split " + split);
  std::unique_ptr<DregNet> net;
  for (const auto& m : eo.methods) {
    if (m == "dreg" && !net) {
      if (!FileExists(weights)) ThrowInputError(weights, "", "DReg-NeRF weights (reg train) for --methods dreg");
      DregModelOptions mo;
      net = std::make_unique<DregNet>(LoadDregWeights(weights, &mo));
      (*net)->to(eo.device);
    }
  }
  std::printf("%-32s %-20s %8s %10s %10s %8s %8s\n", "pair", "method", "overlap", "rot (deg)", "trans/ext", "conf", "time (s)");
  const std::vector<PairEvaluation> rows = EvaluatePairs(pairs, eo, net.get(), [](const PairEvaluation& row) {
    std::printf("%-32s %-20s %8.2f %10.3f %10.4f %8.2f %8.2f\n", row.pair.c_str(), row.method.c_str(), row.overlap,
                row.rotation_deg, row.translation / 2.5, row.confidence, row.seconds);
    std::fflush(stdout);
  });
  const Json summary = SummariseRows(rows, overlap_threshold);
  if (!out.empty()) {
    Json table = Json::array();
    for (const auto& r : rows) {
      table.push_back({{"pair", r.pair}, {"method", r.method}, {"rotation_error_deg", r.rotation_deg},
                       {"translation_error", r.translation}, {"translation_error_fraction", r.translation / 2.5},
                       {"confidence", r.confidence}, {"overlap", r.overlap}, {"seconds", r.seconds}});
    }
    WriteJsonFile(out, {{"pairs_file", pairs_path}, {"split", split}, {"rows", table}, {"summary", summary}});
  }
  return 0;
}

}  // namespace

int RunRegEval(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
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
  double voxel = 0.05;
  app.add_option("--pair", pair, "Registration output (reg register)");
  app.add_option("--ground-truth", gt_path, "ground_truth.json of the rendered dataset");
  app.add_option("--source", source, "Source block index (default 0)");
  app.add_option("--target", target, "Target block index (default 1)");
  app.add_option("--pairs", pairs_path, "pairs.json of reg make-data: evaluate every method on its pairs");
  app.add_option("--methods", methods,
                 "With --pairs: dreg, ransac, fgr (comma separated), or truth: each --refine started at the ground "
                 "truth (where it ends is the floor the blocks' own disagreement sets)")
      ->delimiter(',');
  app.add_option("--refine", refines,
                 "With --pairs: none, icp (on the grids), block-icp (ICP on the grids, then on the blocks' occupied "
                 "points, as reg register; real NeRF pairs only), field (block-icp, then the density fields aligned; "
                 "real NeRF pairs only), comma separated")
      ->delimiter(',');
  app.add_option("--dreg-solver", dreg_solvers, "With --pairs: dreg's pose by ransac, procrustes or both (comma separated)")
      ->delimiter(',');
  app.add_option("--dreg-passes", dreg_passes, "With --pairs: dreg's network passes, e.g. 1,2 (comma separated; default 1)")
      ->delimiter(',')
      ->check(CLI::Range(1, 10));
  app.add_option("--split", split, "With --pairs: the pairs of this split (train, val or all; default val)");
  app.add_option("--max-pairs", max_pairs, "With --pairs: at most this many pairs");
  double overlap_threshold = 0.8;
  app.add_option("--overlap-threshold", overlap_threshold,
                 "With --pairs: success is also counted apart below and above this pair overlap (default 0.8)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--weights", weights, "DReg-NeRF weights for --methods dreg");
  app.add_option("--voxel", voxel, "Classical downsampling voxel (default 0.05)");
  FieldAlignmentOptions eval_field_options;
  app.add_flag("--field-overlap-only", eval_field_options.overlap_only,
               "With --refine field: count only samples where the other block's cameras saw the surface (its grid's "
               "mask; an experiment: no gain on the held-out real pairs, README)");
  GridRegistrationOptions base;
  bool no_flips = false;
  AddIcpOptions(app, &base.icp_points, &no_flips, &base.icp_distance);
  app.add_option("--out", out, "Also write the errors to this JSON file");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const torch::Device dev = ParseDevice(device);
  if (!out.empty()) CheckCanWriteOutput(out, common.force, {pair, gt_path, pairs_path, weights});
  if (!pairs_path.empty()) {
    base.voxel = voxel;
    base.flips = !no_flips;
    const PairEvaluationOptions eo{methods, refines, dreg_solvers, dreg_passes, base, eval_field_options, dev};
    eo.Check();
    return EvalPairs(pairs_path, eo, split, weights, max_pairs, overlap_threshold, out);
  }
  if (pair.empty() || gt_path.empty()) ThrowInputError("reg eval", "", "--pairs FILE, or --pair FILE with --ground-truth FILE");
  const Json pj = ReadJsonFile(pair), gj = ReadJsonFile(gt_path);
  const JsonField p(pj, pair), g(gj, gt_path);
  Sim3d est, src_from_world, tgt_from_world;
  try {
    est = Sim3d::FromMatrix(p["target_from_source"].Matrix(4, 4));
    src_from_world = Sim3d::FromMatrix(g["blocks"][source]["block_from_world"].Matrix(4, 4));
    tgt_from_world = Sim3d::FromMatrix(g["blocks"][target]["block_from_world"].Matrix(4, 4));
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("reg eval: a transform is not a similarity: ") + e.what());
  }
  const Sim3d gt = tgt_from_world * src_from_world.Inverse();
  const double rot = RotationErrorDeg(est.rotation, gt.rotation);
  const double trans = TranslationError(est.translation, gt.translation);
  const double extent = 2.5;
  const bool success = rot <= 5.0 && trans / extent <= 0.05;
  const Json j = {{"rotation_error_deg", rot}, {"translation_error", trans}, {"translation_error_fraction", trans / extent},
                  {"success", success}, {"method", p.StringOr("method", "?")}, {"seconds", p.DoubleOr("seconds", 0)}};
  if (!out.empty()) WriteJsonFile(out, j);
  std::printf("%-22s %10s %12s %10s %8s\n", "method", "rot (deg)", "trans", "trans/ext", "success");
  std::printf("%-22s %10.3f %12.4f %10.4f %8s\n", p.StringOr("method", "?").c_str(), rot, trans, trans / extent,
              success ? "yes" : "no");
  return 0;
}

int RunRegRegisterMany(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Register many NeRF blocks into one frame (block 0's): every pair is registered (FPFH + RANSAC + "
                  "ICP, then by default refined on the two fields), pairs that agree "
                  "(fitness above --min-confidence) become edges of a pose graph, which is solved with a robust loss "
                  "from a cycle-consistent spanning tree. Writes {world_from_block: [4x4...], edges: [...]}.",
                  "nerfreg reg register-many runs/b0.ckpt runs/b1.ckpt runs/b2.ckpt --out runs/poses.json");
  std::vector<std::string> paths;
  std::string out, refine = "field";
  ManyBlockRegistrationOptions o;
  app.add_option("blocks", paths, "Block checkpoints (the first defines the world frame)")->required()->expected(2, 1000);
  app.add_option("--out", out, "Output JSON")->required();
  app.add_option("--min-density", o.min_density, "Density above which a cell's point is used (default 5)");
  app.add_option("--voxel", o.voxel, "Downsampling voxel, scene units (default 0.05)");
  AddMaxPointsOption(app, &o.max_points);
  app.add_option("--min-confidence", o.min_confidence, "Pairs below this fitness are not used (default 0.3)");
  app.add_option("--seed", o.seed, "Random seed");
  app.add_option("--refine", refine, "Each pair: icp, or field (ICP, then the density fields aligned; default)")
      ->check(CLI::IsMember({"icp", "field"}));
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(out, common.force, paths);
  o.refine = RegistrationRefinementFromName(refine);
  const ManyBlockRegistrationResult r = RegisterManyBlocks(paths, o);
  WriteJsonFile(out, r.json);
  LOG_INFO("{} blocks, {} of {} pairs used, {:.1f} s", paths.size(), r.used_edges, r.pairs, r.json["seconds"].get<double>());
  return 0;
}
