#include "nerfreg/pipeline/register_blocks.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "nerfreg/geometry/alignment.h"
#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/reg_baselines/baselines.h"
#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/render/point_splat.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace {

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

const EnumNames<RegistrationMethod> kMethodNames{{{RegistrationMethod::kAuto, "auto"},
                                                  {RegistrationMethod::kDreg, "dreg"},
                                                  {RegistrationMethod::kRansac, "ransac"},
                                                  {RegistrationMethod::kFgr, "fgr"}}};
const EnumNames<RegistrationRefinement> kRefinementNames{{{RegistrationRefinement::kNone, "none"},
                                                          {RegistrationRefinement::kIcp, "icp"},
                                                          {RegistrationRefinement::kField, "field"}}};
const EnumNames<DregSolver> kSolverNames{{{DregSolver::kProcrustes, "procrustes"}, {DregSolver::kRansac, "ransac"}}};

// Two poses within 2 deg and `cell` of each other converge to the same place under the field
// refinement (its basin is a few degrees): they count as the same answer.
bool SamePose(const Sim3d& a, const Sim3d& b, double cell) {
  return RotationErrorDeg(a.rotation, b.rotation) < 2 && TranslationError(a.translation, b.translation) < cell;
}

// Below this confidence (FieldAgreement) reg register warns (docs/registration.md: right pairs
// scored above it, blocks of different objects below).
constexpr double kLowConfidence = 0.65;

}  // namespace

std::string RegistrationMethodName(RegistrationMethod m) { return kMethodNames.Name(m); }
std::string RegistrationRefinementName(RegistrationRefinement r) { return kRefinementNames.Name(r); }
std::string DregSolverName(DregSolver s) { return kSolverNames.Name(s); }
RegistrationMethod RegistrationMethodFromName(const std::string& name, const std::string& option) {
  return kMethodNames.FromName(name, option);
}
RegistrationRefinement RegistrationRefinementFromName(const std::string& name, const std::string& option) {
  return kRefinementNames.FromName(name, option);
}
DregSolver DregSolverFromName(const std::string& name, const std::string& option) {
  return kSolverNames.FromName(name, option);
}

void BlockRegistrationOptions::Check() const {
  field.Check();
  grid.Check();
  // The network's 3D backbone halves the grid four times (reg/backbone.h).
  if (UsesNetwork() && grid.resolution % 16 != 0) {
    ThrowInputError("--grid-resolution", "",
                    "a multiple of 16 for the network (--method dreg or auto), got " + std::to_string(grid.resolution));
  }
  if (!(min_confidence >= 0 && min_confidence <= 1)) ThrowInputError("--min-confidence", "", "in [0, 1]");
  if (config != "" && config != "cpu" && config != "paper") ThrowInputError("--config", "", "cpu or paper");
  if (!(min_density >= 0)) ThrowInputError("--min-density", "", ">= 0");
  if (!(voxel > 0)) ThrowInputError("--voxel", "", "> 0");
  if (max_points < 0) ThrowInputError("--max-points", "", ">= 0");
  if (icp_points != "occupied" && icp_points != "mask") ThrowInputError("--icp-points", "", "occupied or mask");
  if (!(icp_distance > 0)) ThrowInputError("--icp-distance", "", "> 0 (ICP voxels)");
  if (dreg_passes < 1 || dreg_passes > 10) ThrowInputError("--dreg-passes", "", "1..10");
  splats.Check();
}

Json BlockRegistrationOptions::ToJson() const {
  return {{"method", RegistrationMethodName(method)},
          {"refine", RegistrationRefinementName(refine)},
          {"min_confidence", min_confidence},
          {"field_iterations", field.iterations},
          {"field_occupancy_scale", field.occupancy_scale},
          {"field_samples", field.max_samples},
          {"grid_resolution", grid.resolution},
          {"weights", weights},
          {"config", config},
          {"min_density", min_density},
          {"voxel", voxel},
          {"max_points", max_points},
          {"icp_points", icp_points},
          {"flips", flips},
          {"icp_distance", icp_distance},
          {"seed", seed},
          {"dreg_solver", DregSolverName(dreg_solver)},
          {"dreg_passes", dreg_passes},
          {"block_icp", block_icp},
          {"splat_density_scale", splats.density_scale},
          {"splat_blur", splats.blur}};
}

BlockRegistrationOptions BlockRegistrationOptions::FromJson(const Json& json, const std::string& file) {
  const JsonField j(json, file);
  BlockRegistrationOptions o;
  o.method = RegistrationMethodFromName(j["method"].String(), file + ": method");
  o.refine = RegistrationRefinementFromName(j["refine"].String(), file + ": refine");
  o.min_confidence = j["min_confidence"].Double();
  o.field.iterations = j["field_iterations"].Int();
  o.field.occupancy_scale = j["field_occupancy_scale"].Double();
  o.field.max_samples = j["field_samples"].Int();
  o.grid.resolution = j["grid_resolution"].Int();
  o.weights = j["weights"].String();
  o.config = j["config"].String();
  o.min_density = j["min_density"].Double();
  o.voxel = j["voxel"].Double();
  o.max_points = j["max_points"].Int();
  o.icp_points = j["icp_points"].String();
  o.flips = j["flips"].Bool();
  o.icp_distance = j["icp_distance"].Double();
  const double seed = j["seed"].Double();
  if (!(seed >= 0 && seed <= 4294967295.0 && seed == std::floor(seed))) j["seed"].Fail("an integer in [0, 2^32)");
  o.seed = static_cast<unsigned>(seed);
  o.dreg_solver = DregSolverFromName(j["dreg_solver"].String(), file + ": dreg_solver");
  o.dreg_passes = j["dreg_passes"].Int();
  o.block_icp = j["block_icp"].Bool();
  // Absent in T.json files written before splat inputs.
  o.splats.density_scale = j.DoubleOr("splat_density_scale", o.splats.density_scale);
  o.splats.blur = j.DoubleOr("splat_blur", o.splats.blur);
  return o;
}

const Eigen::Matrix3Xd& OccupiedPoints::Source() {
  Extract();
  return src_;
}

const Eigen::Matrix3Xd& OccupiedPoints::Target() {
  Extract();
  return tgt_;
}

void OccupiedPoints::Extract() {
  if (done_) return;
  Timer timer;
  // A block against splats: the block's solid as a shell, as the splats are (else ICP settles the
  // capture's surface inside the block's solid).
  const bool mixed = source_->Kind() != target_->Kind();
  src_ = source_->OccupiedPoints(min_density_, seed_, mixed);
  tgt_ = target_->OccupiedPoints(min_density_, seed_, mixed);
  seconds_ = timer.Seconds();
  done_ = true;
}

// ICP on the D = 32 grids drifts even from the true pose, most at low overlap; on the finer
// occupied points it lands closer (docs/notes/2026-11-24-block-icp-and-agreement.md). It only
// polishes a pose already in its basin. The recorded fitness is no overlap check (blocks of
// different objects reach high fitness too).
Sim3d RefineOnBlockPoints(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& tgt, const Sim3d& start, double voxel,
                          Json* json) {
  if (src.cols() < 3 || tgt.cols() < 3) {
    LOG_WARN("block ICP: fewer than 3 occupied points in a block; pose left as it was");
    *json = {{"fitness", 0.0}, {"seconds", 0.0}, {"source_points", src.cols()}, {"target_points", tgt.cols()}};
    return start;
  }
  ClassicalRegistrationOptions o;
  o.voxel_size = voxel;
  o.normal_radius = 2 * voxel;
  // A Sim(3) start (the paper config's scale solve): the rigid ICP aligns the scaled source.
  const ClassicalRegistrationResult r = RefineWithIcp(start.scale * src, tgt, start.ToRigid(), o);
  *json = {{"fitness", r.fitness},
           {"inlier_rmse", r.inlier_rmse},
           {"seconds", r.seconds},
           {"before", MatrixToJson(start.ToMatrix())}};
  return Sim3d(start.scale, r.target_from_source.rotation, r.target_from_source.translation);
}

Sim3d RefineOnFields(NerfBlock& source, NerfBlock& target, const Eigen::Matrix3Xd& src_points,
                     const Eigen::Matrix3Xd& tgt_points, const Sim3d& start, FieldAlignmentOptions options,
                     double spread, Json* json, const RegGrid* src_grid, const RegGrid* tgt_grid) {
  DensityField src_field = BlockDensityField(source), tgt_field = BlockDensityField(target);
  if (src_grid && tgt_grid) {
    src_field.seen = SeenFromGrid(*src_grid);
    tgt_field.seen = SeenFromGrid(*tgt_grid);
  }
  return RefineOnFields(src_field, tgt_field, src_points, tgt_points, start, options, spread, json);
}

Sim3d RefineOnFields(const DensityField& src_field, const DensityField& tgt_field, const Eigen::Matrix3Xd& src_points,
                     const Eigen::Matrix3Xd& tgt_points, const Sim3d& start, FieldAlignmentOptions options,
                     double spread, Json* json) {
  options.sample_spread = spread;
  const FieldAlignmentResult f =
      AlignFields(src_field, tgt_field, src_points, tgt_points, start.ToRigid(), options, start.scale);
  if (f.iterations == 0)
    LOG_WARN("field refinement: fewer than 10 samples fall inside both blocks; pose left as it was");
  *json = {{"iterations", f.iterations}, {"initial_cost", f.initial_cost}, {"final_cost", f.final_cost},
           {"samples", f.samples},       {"seconds", f.seconds},           {"before", MatrixToJson(start.ToMatrix())}};
  if (f.overlap_fraction >= 0) (*json)["overlap_fraction"] = f.overlap_fraction;
  return Sim3d(start.scale, f.target_from_source.rotation, f.target_from_source.translation);
}

FieldAgreementSamples DrawFieldAgreementSamples(const Eigen::Matrix3Xd& source_points,
                                                const Eigen::Matrix3Xd& target_points, double spread, int max_samples,
                                                unsigned seed) {
  std::mt19937 rng(seed);
  FieldAgreementSamples s;
  s.source = SurfaceBandSamples(source_points, spread, max_samples, rng);
  s.target = SurfaceBandSamples(target_points, spread, max_samples, rng);
  return s;
}

namespace {

// o = 1 - exp(-scale * sigma) at p ([3, N], the field's frame).
Eigen::VectorXd Occupancy(const DensityField& f, const Eigen::Matrix3Xd& p, double scale) {
  if (p.cols() == 0) return Eigen::VectorXd();
  torch::NoGradGuard no_grad;
  const torch::Tensor x =
      torch::from_blob(const_cast<double*>(p.data()), {p.cols(), 3}, torch::kDouble).to(torch::kFloat).contiguous();
  const torch::Tensor sigma = f.density(x).to(torch::kDouble).contiguous().view({-1});
  TORCH_CHECK(sigma.size(0) == p.cols(), "ScoreFieldAgreement: the density field returned ", sigma.size(0),
              " values for ", p.cols(), " points");
  const Eigen::VectorXd s = Eigen::Map<const Eigen::VectorXd>(sigma.data_ptr<double>(), sigma.size(0));
  return (1.0 - (-scale * s.array().max(0.0)).exp()).matrix();
}

}  // namespace

FieldAgreement ScoreFieldAgreement(const DensityField& source, const DensityField& target,
                                   const FieldAgreementSamples& samples, const Sim3d& target_from_source,
                                   double occupancy_scale) {
  const Sim3d source_from_target = target_from_source.Inverse();
  double ab = 0, aa_bb = 0, squared = 0;
  int inside = 0;
  // Samples of `own` (their frame) carried into `other` by `other_from_own`.
  auto accumulate = [&](const DensityField& own, const DensityField& other, const Eigen::Matrix3Xd& p,
                        const Sim3d& other_from_own) {
    Eigen::Matrix3Xd moved(3, p.cols());
    for (Eigen::Index i = 0; i < p.cols(); ++i) moved.col(i) = other_from_own * Eigen::Vector3d(p.col(i));
    const Eigen::VectorXd a = Occupancy(own, p, occupancy_scale), b = Occupancy(other, moved, occupancy_scale);
    for (Eigen::Index i = 0; i < p.cols(); ++i) {
      const bool in = other.box.contains(Eigen::Vector3d(moved.col(i)));
      const double bi = in ? b(i) : 0.0;
      ab += a(i) * bi;
      aa_bb += a(i) * a(i) + bi * bi;
      if (in) {
        squared += (a(i) - bi) * (a(i) - bi);
        ++inside;
      }
    }
  };
  accumulate(source, target, samples.source, target_from_source);
  accumulate(target, source, samples.target, source_from_target);
  FieldAgreement g;
  g.samples = static_cast<int>(samples.source.cols() + samples.target.cols());
  g.inside_fraction = g.samples > 0 ? double(inside) / g.samples : 0;
  g.cost = inside > 0 ? squared / inside : 0;
  g.confidence = aa_bb > 0 ? 2 * ab / aa_bb : 0;
  return g;
}

size_t ChooseCandidate(const DensityField& source, const DensityField& target, const FieldAgreementSamples& samples,
                       const std::vector<Sim3d>& poses, double occupancy_scale, std::vector<FieldAgreement>* scores) {
  if (poses.empty()) throw std::invalid_argument("ChooseCandidate: no candidate poses");
  size_t best = 0;
  std::vector<FieldAgreement> s;
  for (size_t k = 0; k < poses.size(); ++k) {
    s.push_back(ScoreFieldAgreement(source, target, samples, poses[k], occupancy_scale));
    if (s[k].confidence > s[best].confidence) best = k;
  }
  if (scores) *scores = std::move(s);
  return best;
}

namespace {

// One registration job's state: the blocks, their occupied points (shared by block ICP, the
// classical methods and the scoring) and the candidates found so far.
class BlockRegistration {
 public:
  BlockRegistration(RegistrationInput& source, RegistrationInput& target, const BlockRegistrationOptions& options,
                    DregNet* net)
      : source_(source),
        target_(target),
        o_(options),
        net_(net),
        occupied_(source, target, options.min_density, options.seed) {
    grid_cell_ = o_.grid.side / o_.grid.resolution;
  }

  RegistrationResult Run() {
    Timer timer;
    result_.options = o_;
    result_.source_kind = source_.Kind();
    result_.target_kind = target_.Kind();
    bool run_classical = o_.method == RegistrationMethod::kRansac || o_.method == RegistrationMethod::kFgr;
    if (o_.UsesNetwork()) run_classical = RunOnGrids();
    if (run_classical) RunClassical();
    if (o_.refine == RegistrationRefinement::kField) RefineCandidatesOnFields();
    Choose();
    result_.seconds = timer.Seconds();
    return std::move(result_);
  }

 private:
  void Warn(const std::string& message) {
    LOG_WARN("{}", message);
    result_.warnings.push_back(message);
  }

  GridRegistrationOptions GridOptions(const std::string& method) const {
    GridRegistrationOptions ro;
    ro.method = method;
    ro.dreg_solver = DregSolverName(o_.dreg_solver);
    ro.dreg_passes = o_.dreg_passes;
    ro.icp = o_.refine != RegistrationRefinement::kNone;
    ro.icp_points = o_.icp_points;
    ro.flips = o_.flips;
    ro.icp_distance = o_.icp_distance;
    ro.voxel = o_.voxel;
    ro.seed = o_.seed;
    return ro;
  }

  void BlockIcp(RegistrationCandidate* c) {
    c->target_from_source = RefineOnBlockPoints(occupied_.Source(), occupied_.Target(), c->target_from_source, o_.voxel,
                                                &c->extra["block_icp"]);
    c->method += "+block";
  }

  // dreg (and with auto + kField, FPFH + RANSAC on the same grids). Returns whether the classical
  // method on the occupied points runs too.
  bool RunOnGrids() {
    Timer t_grid;
    GridExtractionOptions go = o_.grid;
    go.seed = o_.seed;
    const RegGrid gs = source_.ExtractGrid(go), gt = target_.ExtractGrid(go);
    const double grid_seconds = t_grid.Seconds();
    const GridRegistrationOptions ro = GridOptions("dreg");
    const GridRegistrationResult r = RegisterGrids(gs, gt, ro, net_);
    if (r.source_points < 100 || r.target_points < 100) {
      Warn(fmt::format("few surface voxels (source {}, target {}): is a block empty?", r.source_points,
                       r.target_points));
    }
    RegistrationCandidate c;
    c.method = r.method;
    c.target_from_source = Sim3d::FromMatrix(r.target_from_source, 1e-3);
    c.method_score = r.confidence;
    c.extra = {{"register_seconds", r.seconds}, {"grid_seconds", grid_seconds},     {"weights", o_.weights},
               {"half_turn", r.flip},           {"source_points", r.source_points}, {"target_points", r.target_points}};
    c.source_points = PointsToEigen(gs.MaskedXyz());
    c.target_points = PointsToEigen(gt.MaskedXyz());
    const bool is_auto = o_.method == RegistrationMethod::kAuto, field = o_.refine == RegistrationRefinement::kField;
    // auto without kField drops a low-confidence dreg answer for RANSAC: no block ICP then.
    const bool falls_back = is_auto && !field && r.confidence < o_.min_confidence;
    const bool block_icp = ro.icp && o_.block_icp;
    if (block_icp && !falls_back) BlockIcp(&c);
    result_.candidates.push_back(c);
    if (!is_auto) return false;
    if (field) {
      // FPFH + RANSAC on the same grids too: on the surface points of a grid it registers pairs it
      // fails on the blocks' occupied points, and the other way round
      // (docs/notes/2026-11-23-grids-icp-half-turn.md, "Two FPFH candidates").
      const GridRegistrationOptions rg = GridOptions("ransac");
      const GridRegistrationResult g = RegisterGrids(gs, gt, rg, nullptr);
      RegistrationCandidate cg = c;
      cg.method = "ransac-grid" + std::string(rg.icp ? "+icp" : "");
      cg.target_from_source = Sim3d::FromMatrix(g.target_from_source, 1e-3);
      cg.method_score = g.confidence;
      cg.extra = {{"grid_seconds", grid_seconds},
                  {"register_seconds", g.seconds},
                  {"source_points", g.source_points},
                  {"target_points", g.target_points}};
      if (block_icp) BlockIcp(&cg);
      result_.candidates.push_back(cg);
      return true;  // and on the occupied points; the fields choose
    }
    if (falls_back) {
      Warn(fmt::format("DReg-NeRF confidence {:.2f} < {:.2f}: falling back to FPFH + RANSAC", r.confidence,
                       o_.min_confidence));
      result_.fallback = {{"method", r.method},
                          {"confidence", r.confidence},
                          {"target_from_source", MatrixToJson(r.target_from_source)}};
      result_.candidates.clear();
      return true;
    }
    return false;
  }

  // FPFH + RANSAC / FGR on the blocks' occupied points.
  void RunClassical() {
    RegistrationCandidate c;
    c.source_points = occupied_.Source();
    c.target_points = occupied_.Target();
    const Eigen::Index ns = c.source_points.cols(), nt = c.target_points.cols();
    if (ns < 100 || nt < 100) {
      Warn(fmt::format("too few occupied points (source {}, target {}); registration is unreliable", ns, nt));
    }
    ClassicalRegistrationOptions options;
    options.method = o_.method == RegistrationMethod::kFgr ? "fgr" : "ransac";
    options.icp = o_.refine != RegistrationRefinement::kNone;
    options.voxel_size = o_.voxel;
    options.normal_radius = 2 * o_.voxel;
    options.feature_radius = 5 * o_.voxel;
    options.seed = o_.seed;
    options.max_points = o_.max_points;
    ClassicalRegistrationResult r;
    if (ns >= 3 && nt >= 3) r = RegisterPointClouds(c.source_points, c.target_points, options);
    c.method = options.method + (options.icp ? "+icp" : "");
    c.target_from_source = Sim3d(r.target_from_source);
    c.method_score = r.fitness;
    c.extra = {{"inlier_rmse", r.inlier_rmse},
               {"points_seconds", occupied_.Seconds()},
               {"register_seconds", r.seconds},
               {"source_points", ns},
               {"target_points", nt},
               {"feature_voxel", r.feature_voxel},
               {"feature_points", {r.source_points, r.target_points}}};
    result_.candidates.push_back(c);
  }

  // Each candidate refined on the fields; a start that is the same answer as an earlier
  // candidate's (SamePose) is refined once: the refinement is the costly step (refined_with).
  void RefineCandidatesOnFields() {
    auto& cs = result_.candidates;
    std::vector<Sim3d> starts;
    for (const auto& c : cs) starts.push_back(c.target_from_source);
    for (size_t k = 0; k < cs.size(); ++k) {
      RegistrationCandidate& c = cs[k];
      if (c.source_points.cols() < 3 || c.target_points.cols() < 3) continue;
      size_t same = k;
      for (size_t j = 0; j < k && same == k; ++j)
        if (cs[j].field.is_object() && SamePose(starts[k], starts[j], grid_cell_)) same = j;
      if (same < k) {
        c.target_from_source = cs[same].target_from_source;
        c.field = cs[same].field;
        c.field["refined_with"] = cs[same].method;
      } else {
        c.target_from_source = RefineOnFields(source_.Field(), target_.Field(), c.source_points, c.target_points,
                                              c.target_from_source, o_.field, grid_cell_, &c.field);
      }
      c.method += "+field";
    }
  }

  // Every candidate's final pose scored on the same samples (around both blocks' occupied points)
  // with the same measure, so candidates of different methods compare and the kept one's
  // confidence means the same whichever method found it.
  void Score() {
    auto& cs = result_.candidates;
    const FieldAgreementSamples samples =
        DrawFieldAgreementSamples(occupied_.Source(), occupied_.Target(), grid_cell_, o_.field.max_samples, o_.seed);
    const DensityField src = source_.Field(), tgt = target_.Field();
    std::vector<Sim3d> poses;
    for (const auto& c : cs) poses.push_back(c.target_from_source);
    std::vector<FieldAgreement> scores;
    const size_t best = ChooseCandidate(src, tgt, samples, poses, o_.field.occupancy_scale, &scores);
    for (size_t k = 0; k < cs.size(); ++k) cs[k].agreement = scores[k];
    // Only field-refined candidates are compared: without kField there is one (auto falls back
    // instead of choosing).
    result_.chosen = o_.refine == RegistrationRefinement::kField ? best : 0;
  }

  void Choose() {
    auto& cs = result_.candidates;
    Score();
    const size_t best = result_.chosen;
    const RegistrationCandidate& c = cs[best];
    result_.target_from_source = c.target_from_source;
    result_.method = c.method;
    result_.confidence = c.agreement.confidence;
    if (c.agreement.confidence < kLowConfidence) {
      Warn(fmt::format(
          "low confidence {:.2f}: the two fields disagree at the kept pose; the blocks may not overlap or the "
          "pose is wrong",
          c.agreement.confidence));
    }
    // How many other refined candidates ended at the kept pose. On real blocks this is the signal
    // that tells right from wrong poses where the network's confidence and the field cost do not
    // (docs/notes/2026-11-24-block-icp-and-agreement.md, "How to tell a wrong pose").
    if (o_.refine != RegistrationRefinement::kField || cs.size() < 2) return;
    int agreeing = 0;
    for (size_t k = 0; k < cs.size(); ++k) {
      if (k != best && cs[k].field.is_object())
        agreeing += SamePose(cs[k].target_from_source, c.target_from_source, grid_cell_);
    }
    result_.agreeing_candidates = agreeing;
    if (agreeing == 0) {
      Warn(fmt::format("no other candidate ({} tried) ended at the kept pose: it may be wrong; check the overlays",
                       cs.size()));
    }
  }

  RegistrationInput& source_;
  RegistrationInput& target_;
  const BlockRegistrationOptions& o_;
  DregNet* net_;
  OccupiedPoints occupied_;
  double grid_cell_ = 0;
  RegistrationResult result_;
};

}  // namespace

RegistrationResult RegisterBlocks(RegistrationInput& source, RegistrationInput& target,
                                  const BlockRegistrationOptions& options, DregNet* net) {
  options.Check();
  if (options.UsesNetwork() && !net)
    throw std::invalid_argument("RegisterBlocks: method dreg / auto needs the network");
  return BlockRegistration(source, target, options, net).Run();
}

RegistrationResult RegisterBlocks(NerfBlock& source, NerfBlock& target, const BlockRegistrationOptions& options,
                                  DregNet* net) {
  NerfBlockInput s(source), t(target);
  return RegisterBlocks(s, t, options, net);
}

namespace {

Json AgreementJson(const FieldAgreement& g) {
  return {
      {"confidence", g.confidence}, {"cost", g.cost}, {"inside_fraction", g.inside_fraction}, {"samples", g.samples}};
}

}  // namespace

Json RegistrationResult::ToJson() const {
  const RegistrationCandidate& c = Chosen();
  Json others = Json::array();
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (k == chosen) continue;
    const RegistrationCandidate& o = candidates[k];
    others.push_back({{"method", o.method},
                      {"confidence", o.agreement.confidence},
                      {"method_score", o.method_score},
                      {"agreement", AgreementJson(o.agreement)},
                      {"field", o.field},
                      {"target_from_source", MatrixToJson(o.target_from_source.ToMatrix())}});
  }
  Json j = {{"target_from_source", MatrixToJson(target_from_source.ToMatrix())},
            {"scale", target_from_source.scale},
            {"field", c.field},
            {"confidence", confidence},
            {"method_score", c.method_score},
            {"agreement", AgreementJson(c.agreement)},
            {"seconds", seconds},
            {"method", method},
            {"fallback_from", fallback.is_null() ? Json() : fallback},
            {"not_chosen", others},
            {"agreeing_candidates", agreeing_candidates >= 0 ? Json(agreeing_candidates) : Json()},
            {"warnings", warnings},
            {"source_kind", source_kind},
            {"target_kind", target_kind}};
  j.update(c.extra);
  j["options"] = options.ToJson();
  return j;
}

// The network for dreg / auto: the weights must exist and, with --config, be of that config.
DregNet LoadCheckedDregNet(const BlockRegistrationOptions& o) {
  if (o.weights.empty() || !FileExists(o.weights)) {
    ThrowInputError(o.weights.empty() ? "--weights" : o.weights, "",
                    "DReg-NeRF weights (reg train), or --method ransac / fgr");
  }
  DregModelOptions model_options;
  DregNet net = LoadDregWeights(o.weights, &model_options);
  if (!o.config.empty()) {
    CheckDregOptionsMatch(model_options, o.config == "paper" ? DregModelOptions::Paper() : DregModelOptions::Cpu(),
                          o.weights);
  }
  net->to(o.device);
  return net;
}

// Before / after: source in orange, target in blue, from three fixed viewpoints, beside `out`.
void WriteRegistrationOverlays(const std::string& out, const RegistrationResult& result) {
  const Eigen::Matrix3Xd& src = result.Chosen().source_points;
  const Eigen::Matrix3Xd& tgt = result.Chosen().target_points;
  const Sim3d& target_from_source = result.target_from_source;
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

}  // namespace nerfreg
