#include "nerfreg/registration/register_blocks.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "nerfreg/geometry/alignment.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/registration/grid_registration.h"
#include "nerfreg/registration/point_registration.h"
#include "nerfreg/registration/scale_normalization.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace {

// Two poses within 2 deg, `cell` and 5 % in scale of each other converge to the same place under
// the field refinement (its basin is a few degrees): they count as the same answer.
bool SamePose(const Sim3d& a, const Sim3d& b, double cell) {
  return RotationErrorDeg(a.rotation, b.rotation) < 2 && TranslationError(a.translation, b.translation) < cell &&
         std::abs(std::log(a.scale / b.scale)) < 0.05;
}

// How errors name an input: its file, else its role ("source", "target").
std::string InputName(const RegistrationInput* input, const char* role) {
  return input != nullptr && !input->Path().empty() ? input->Path() : std::string(role);
}

// Each input's occupied points in its own frame, as the pair extracts them (a block against
// splats: its shell), for its normalisation.
Sim3d NormalizationOf(RegistrationInput& input, bool mixed, const BlockRegistrationOptions& o, const char* role,
                      Json* record) {
  const std::string name = InputName(&input, role);
  const Eigen::Matrix3Xd points = input.OccupiedPoints(o.min_density, o.seed, mixed);
  CheckOccupied(points.cols(), name, o.min_density);
  const Sim3d n = NormalizationFor(points, name);
  *record = NormalizationJson(n, OccupiedRadius(points));
  return n;
}

// A candidate found between the normalised frames, carried back to the inputs' own.
void Denormalize(const Sim3d& source_n, const Sim3d& target_n, RegistrationResult* r) {
  r->target_from_source = target_n.Inverse() * r->target_from_source * source_n;
}

// One registration job's state: the pair (its grids and occupied points, shared by every
// candidate and the scoring) and the candidates found so far.
class BlockRegistration {
 public:
  BlockRegistration(RegistrationInput& source, RegistrationInput& target, const BlockRegistrationOptions& options,
                    DregNet* net)
      : source_(&source), target_(&target), pair_(source, target, options), o_(options), net_(net) {}

  BlockRegistrationResult Run() {
    Timer timer;
    CheckOccupied(pair_.SourcePoints().cols(), InputName(source_, "source"), o_.min_density);
    CheckOccupied(pair_.TargetPoints().cols(), InputName(target_, "target"), o_.min_density);
    result_.options = o_;
    result_.source_kind = pair_.SourceKind();
    result_.target_kind = pair_.TargetKind();
    bool run_classical = o_.method == RegistrationMethod::kRansac || o_.method == RegistrationMethod::kFgr;
    if (o_.UsesNetwork()) run_classical = RunOnGrids();
    if (run_classical) RunClassical();
    if (o_.refine == RegistrationRefinement::kField) RefineCandidatesOnFields();
    Choose();
    JudgeRegistration(&result_);
    result_.seconds = timer.Seconds();
    return std::move(result_);
  }

 private:
  void Warn(const std::string& message) {
    LOG_WARN("{}", message);
    result_.warnings.push_back(message);
  }

  // dreg (and with auto + kField, FPFH + RANSAC on the same grids). Returns whether the classical
  // method on the occupied points runs too.
  bool RunOnGrids() {
    RegistrationResult c = RegisterCoarse(pair_, RegistrationMethod::kDreg, RegistrationCloud::kGridMask, o_, net_);
    if (c.source_points < 100 || c.target_points < 100) {
      Warn(fmt::format("few surface voxels (source {}, target {}): is a block empty?", c.source_points,
                       c.target_points));
    }
    c.details = {
        {"register_seconds", c.seconds}, {"grid_seconds", pair_.GridSeconds()}, {"weights", o_.weights},
        {"half_turn", c.half_turn},      {"source_points", c.source_points},    {"target_points", c.target_points}};
    const bool is_auto = o_.method == RegistrationMethod::kAuto, field = o_.refine == RegistrationRefinement::kField;
    // auto without kField drops a low-confidence dreg answer for RANSAC: no block ICP then.
    const bool falls_back = is_auto && !field && c.method_score < o_.min_confidence;
    const bool block_icp = o_.refine != RegistrationRefinement::kNone && o_.block_icp;
    if (block_icp && !falls_back) RefineOnBlockPoints(pair_, o_, &c);
    result_.candidates.push_back(c);
    if (!is_auto) return false;
    if (field) {
      // FPFH + RANSAC on the same grids too: on the surface points of a grid it registers pairs it
      // fails on the blocks' occupied points, and the other way round
      // (docs/notes/2026-11-23-grids-icp-half-turn.md, "Two FPFH candidates").
      RegistrationResult g =
          RegisterCoarse(pair_, RegistrationMethod::kRansac, RegistrationCloud::kGridMask, o_, nullptr);
      g.method = "ransac-grid" + std::string(o_.refine != RegistrationRefinement::kNone ? "+icp" : "");
      g.details = {{"grid_seconds", pair_.GridSeconds()},
                   {"register_seconds", g.seconds},
                   {"source_points", g.source_points},
                   {"target_points", g.target_points}};
      if (block_icp) RefineOnBlockPoints(pair_, o_, &g);
      result_.candidates.push_back(g);
      return true;  // and on the occupied points; the fields choose
    }
    if (falls_back) {
      Warn(fmt::format("DReg-NeRF confidence {:.2f} < {:.2f}: falling back to FPFH + RANSAC", c.method_score,
                       o_.min_confidence));
      result_.fallback = {{"method", c.method},
                          {"confidence", c.method_score},
                          {"target_from_source", MatrixToJson(c.target_from_source.ToMatrix())}};
      result_.candidates.clear();
      return true;
    }
    return false;
  }

  // FPFH + RANSAC / FGR on the inputs' occupied points.
  void RunClassical() {
    const Eigen::Index ns = pair_.SourcePoints().cols(), nt = pair_.TargetPoints().cols();
    if (ns < 100 || nt < 100) {
      Warn(fmt::format("too few occupied points (source {}, target {}); registration is unreliable", ns, nt));
    }
    const RegistrationMethod method =
        o_.method == RegistrationMethod::kFgr ? RegistrationMethod::kFgr : RegistrationMethod::kRansac;
    RegistrationResult c = RegisterCoarse(pair_, method, RegistrationCloud::kOccupied, o_, nullptr);
    c.details["points_seconds"] = pair_.PointsSeconds();
    result_.candidates.push_back(c);
  }

  // Each candidate refined on the fields; a start that is the same answer as an earlier
  // candidate's (SamePose) is refined once: the refinement is the costly step (refined_with).
  void RefineCandidatesOnFields() {
    auto& cs = result_.candidates;
    std::vector<Sim3d> starts;
    for (const auto& c : cs) starts.push_back(c.target_from_source);
    for (size_t k = 0; k < cs.size(); ++k) {
      RegistrationResult& c = cs[k];
      if (pair_.SourceCloud(c.cloud).cols() < 3 || pair_.TargetCloud(c.cloud).cols() < 3) continue;
      size_t same = k;
      for (size_t j = 0; j < k && same == k; ++j)
        if (cs[j].field.is_object() && SamePose(starts[k], starts[j], pair_.GridCell())) same = j;
      if (same < k) {
        c.target_from_source = cs[same].target_from_source;
        c.field = cs[same].field;
        c.field["refined_with"] = cs[same].method;
        c.method += "+field";
      } else {
        RefineOnFields(pair_, o_, &c);
      }
    }
  }

  // Every candidate's final pose scored on the same samples (around both inputs' occupied points)
  // with the same measure, so candidates of different methods compare and the kept one's
  // confidence means the same whichever method found it.
  void Score() {
    auto& cs = result_.candidates;
    samples_ = DrawFieldAgreementSamples(pair_.SourcePoints(), pair_.TargetPoints(), pair_.GridCell(),
                                         o_.field.max_samples, o_.seed);
    const DensityField src = pair_.SourceField(), tgt = pair_.TargetField();
    std::vector<Sim3d> poses;
    for (const auto& c : cs) poses.push_back(c.target_from_source);
    std::vector<FieldAgreement> scores;
    const size_t best = ChooseCandidate(src, tgt, samples_, poses, o_.field.occupancy_scale, &scores);
    for (size_t k = 0; k < cs.size(); ++k) {
      cs[k].agreement = scores[k];
      cs[k].confidence = scores[k].confidence;
    }
    // Only field-refined candidates are compared: without kField there is one (auto falls back
    // instead of choosing).
    result_.chosen = o_.refine == RegistrationRefinement::kField ? best : 0;
  }

  // With a free scale and kField, the kept pose polished with its scale held (PolishWithScaleHeld,
  // registration/registration_chain.h) and scored again on the same samples. Only the kept one:
  // the polish costs a field refinement.
  void PolishChosen() {
    RegistrationResult& c = result_.candidates[result_.chosen];
    const std::string method = c.method;
    PolishWithScaleHeld(pair_, o_, &c);
    if (c.method == method) return;  // not run, or not kept
    c.agreement = ScoreFieldAgreement(pair_.SourceField(), pair_.TargetField(), samples_, c.target_from_source,
                                      o_.field.occupancy_scale);
    c.confidence = c.agreement.confidence;
  }

  // The turn check (register_blocks.h, kTurnSwitchMargin): the kept candidate's pose turned about
  // the source's principal axes, each turn refined by block ICP (rigid, the scale held) and scored
  // on Score's samples. A turn clearly better replaces the pose (polished again); the margin left
  // between the kept pose and the best other is what JudgeRegistration reads.
  void CheckTurns() {
    RegistrationResult& c = result_.candidates[result_.chosen];
    const DensityField src = pair_.SourceField(), tgt = pair_.TargetField();
    const std::vector<TurnedPose> turned = TurnedPoses(src, tgt, pair_.SourcePoints(), pair_.TargetPoints(), samples_,
                                                       c.target_from_source, o_.voxel, o_.field.occupancy_scale);
    std::vector<Sim3d> poses;
    std::vector<FieldAgreement> agreements;
    std::vector<double> scores;
    Json tried = Json::array();
    for (const TurnedPose& t : turned) {
      poses.push_back(t.target_from_source);
      agreements.push_back(t.agreement);
      scores.push_back(t.agreement.confidence);
      tried.push_back({{"axis", t.axis}, {"angle_deg", t.angle_deg}, {"confidence", t.agreement.confidence}});
    }
    Json record = {{"confidence", c.confidence}, {"turns", tried}, {"switched", false}};
    const size_t best = std::max_element(scores.begin(), scores.end()) - scores.begin();
    if (scores[best] > c.confidence + kTurnSwitchMargin) {
      // The turn becomes the kept pose, polished as the kept pose was; the pose it replaces is
      // now one of its turns.
      record["switched"] = true;
      record["switched_from"] = MatrixToJson(c.target_from_source.ToMatrix());
      record["switched_to_turn"] = best;
      SwitchToTurn(best, "+turn", &poses, &agreements, &scores);
    }
    SetTurnMargin(poses, scores, &record);
    if (result_.turn_margin < kTurnAmbiguityMargin) {
      record["colour"] = TurnsByColour(&poses, &agreements, &scores);
      if (record["colour"]["switched"].get<bool>()) SetTurnMargin(poses, scores, &record);
    }
    result_.turns = record;
  }

  // The kept candidate becomes turn k (polished as the kept pose was); the pose it replaces takes
  // turn k's place among the turns.
  void SwitchToTurn(size_t k, const char* method, std::vector<Sim3d>* poses, std::vector<FieldAgreement>* agreements,
                    std::vector<double>* scores) {
    RegistrationResult& c = result_.candidates[result_.chosen];
    std::swap(c.target_from_source, (*poses)[k]);
    std::swap(c.agreement, (*agreements)[k]);
    c.confidence = c.agreement.confidence;
    (*scores)[k] = (*agreements)[k].confidence;
    c.method += method;
    const RegistrationResult switched = c;
    // With a free scale, the fields are aligned again at the turned pose (scale free) before the
    // polish holds the scale: the one it had was fitted at the pose the turn replaced. On
    // bench/registration_sim3.sh's trained blocks of objects 6009 and 6010, where turns replaced a
    // pose 90 deg off, the scale errors -1.76, -2.79 and -1.94 % became -0.42, -0.36 and -1.41 %
    // (docs/registration.md, section 7).
    if (o_.scale == ScaleMode::kFree && o_.refine == RegistrationRefinement::kField) {
      const Json before_turn = c.field;
      RefineOnFields(pair_, o_, &c);
      c.field["before_turn"] = before_turn;
      c.agreement = ScoreFieldAgreement(pair_.SourceField(), pair_.TargetField(), samples_, c.target_from_source,
                                        o_.field.occupancy_scale);
      c.confidence = c.agreement.confidence;
    }
    PolishChosen();
    if (c.confidence < switched.confidence) c = switched;  // the polish lost agreement: the turn's ICP pose stands
  }

  // The best other pose: a turn (or the pose a turn replaced) that did not come back to the kept
  // one; turn_margin is the kept pose's confidence minus its.
  void SetTurnMargin(const std::vector<Sim3d>& poses, const std::vector<double>& scores, Json* record) {
    const RegistrationResult& c = result_.candidates[result_.chosen];
    double other = -1;
    for (size_t k = 0; k < poses.size(); ++k)
      if (!SamePose(poses[k], c.target_from_source, pair_.GridCell())) other = std::max(other, scores[k]);
    result_.turn_margin = other >= 0 ? c.confidence - other : std::numeric_limits<double>::quiet_NaN();
    (*record)["margin"] = other >= 0 ? Json(result_.turn_margin) : Json();
  }

  // The fields' agreement is density alone; where turns agree nearly as well as the kept pose,
  // colour tells them apart (register_blocks.h, kTurnColourMargin): each of those poses'
  // GridAgreement on the pair's registration grids. The one whose colours agree best by the margin
  // is kept (switched to if a turn) and turn_colour_margin set; otherwise it stays unset.
  Json TurnsByColour(std::vector<Sim3d>* poses, std::vector<FieldAgreement>* agreements, std::vector<double>* scores) {
    const RegistrationResult& c = result_.candidates[result_.chosen];
    const RegGrid& source = pair_.SourceGrid();
    const RegGrid& target = pair_.TargetGrid();
    const double kept = GridAgreement(source, target, c.target_from_source);
    // The poses the fields cannot tell from the kept one: (turn index, its colour agreement).
    std::vector<std::pair<size_t, double>> alike;
    Json tried = Json::array();
    for (size_t k = 0; k < poses->size(); ++k) {
      if (SamePose((*poses)[k], c.target_from_source, pair_.GridCell()) ||
          (*scores)[k] < c.confidence - kTurnAmbiguityMargin)
        continue;
      alike.emplace_back(k, GridAgreement(source, target, (*poses)[k]));
      tried.push_back({{"turn", k}, {"confidence", (*scores)[k]}, {"colour", alike.back().second}});
    }
    Json record = {{"kept", kept}, {"turns", tried}, {"switched", false}};
    // The best of the kept pose and those turns, and the best of the rest.
    double best = kept, second = -1;
    size_t best_turn = poses->size();  // none: the kept pose
    for (const auto& [k, colour] : alike) {
      if (colour > best) {
        second = best;
        best = colour;
        best_turn = k;
      } else {
        second = std::max(second, colour);
      }
    }
    if (alike.empty()) return record;  // the caller asks only where a turn is that close
    const double margin = best - second;
    record["margin"] = margin;
    if (margin < kTurnColourMargin) return record;
    if (best_turn < poses->size()) {
      record["switched"] = true;
      record["switched_from"] = MatrixToJson(c.target_from_source.ToMatrix());
      record["switched_to_turn"] = best_turn;
      SwitchToTurn(best_turn, "+colour-turn", poses, agreements, scores);
    }
    result_.turn_colour_margin = margin;
    return record;
  }

  void Choose() {
    auto& cs = result_.candidates;
    Score();
    PolishChosen();
    if (o_.refine == RegistrationRefinement::kField && o_.check_turns) CheckTurns();
    const size_t best = result_.chosen;
    const RegistrationResult& c = cs[best];
    static_cast<RegistrationResult&>(result_) = c;
    result_.source_cloud = pair_.SourceCloud(c.cloud);
    result_.target_cloud = pair_.TargetCloud(c.cloud);
    if (c.confidence < kLowConfidence) {
      Warn(fmt::format(
          "low confidence {:.2f}: the two fields disagree at the kept pose; the blocks may not overlap or the "
          "pose is wrong",
          c.confidence));
    }
    // How many other refined candidates ended at the kept pose. On real blocks this is the signal
    // that tells right from wrong poses where the network's confidence and the field cost do not
    // (docs/notes/2026-11-24-block-icp-and-agreement.md, "How to tell a wrong pose").
    if (o_.refine != RegistrationRefinement::kField || cs.size() < 2) return;
    int agreeing = 0;
    for (size_t k = 0; k < cs.size(); ++k) {
      if (k != best && cs[k].field.is_object())
        agreeing += SamePose(cs[k].target_from_source, c.target_from_source, pair_.GridCell());
    }
    result_.agreeing_candidates = agreeing;
    if (agreeing == 0) {
      Warn(fmt::format("no other candidate ({} tried) ended at the kept pose: it may be wrong; check the overlays",
                       cs.size()));
    }
  }

  RegistrationInput *source_, *target_;
  RegistrationPair pair_;
  const BlockRegistrationOptions& o_;
  DregNet* net_;
  FieldAgreementSamples samples_;  // Score's, kept for the polished pose
  BlockRegistrationResult result_;
};

}  // namespace

void JudgeRegistration(BlockRegistrationResult* r) {
  const bool same_kind = r->source_kind == r->target_kind;
  const int agreeing = r->agreeing_candidates;
  // A pose another candidate ended at needs only the floor; an unconfirmed one the threshold.
  const double needed = agreeing > 0 ? (same_kind ? kConfirmedConfidenceFloor : kConfirmedConfidenceFloorMixed)
                                     : (same_kind ? kUntrustedConfidence : kUntrustedConfidenceMixed);
  if (r->confidence >= needed) {
    // Both false for NaN: not checked, or colour not needed.
    if (r->turn_margin < kTurnAmbiguityMargin && !(r->turn_colour_margin >= kTurnColourMargin)) {
      r->status = "untrusted";
      r->status_reason = fmt::format(
          "the inputs agree nearly as well with the source turned about one of its axes (confidence {:.2f}, the "
          "turn's {:.2f}; margin {:.2f} < {:.2f}), and their colours do not tell the turns apart: the object may "
          "look alike turned, and the pose may be a turn away from the right one",
          r->confidence, r->confidence - r->turn_margin, r->turn_margin, kTurnAmbiguityMargin);
      return;
    }
    r->status = "registered";
    r->status_reason.clear();
    return;
  }
  r->status = "untrusted";
  if (agreeing > 0) {
    r->status_reason = fmt::format(
        "confidence {:.2f} < {:.2f} although {} other candidate{} at the kept pose: candidates can end in the "
        "same wrong pose, and the inputs agree there too little to believe it",
        r->confidence, needed, agreeing, agreeing == 1 ? " ended" : "s ended");
  } else {
    r->status_reason = fmt::format(
        "confidence {:.2f} < {:.2f} and {}: the inputs may not overlap, or show different things", r->confidence,
        needed, agreeing == 0 ? "no other candidate ended at the kept pose" : "no other candidate to confirm it");
  }
}

std::vector<TurnedPose> TurnedPoses(const DensityField& source, const DensityField& target,
                                    const Eigen::Matrix3Xd& source_points, const Eigen::Matrix3Xd& target_points,
                                    const FieldAgreementSamples& samples, const Sim3d& kept, double voxel,
                                    double occupancy_scale) {
  Eigen::Vector3d centroid;
  const Eigen::Matrix3d axes = PrincipalAxes(source_points, &centroid);
  std::vector<TurnedPose> turned;
  std::vector<Sim3d> starts;
  for (int axis = 0; axis < 3; ++axis) {
    for (const double angle : {180.0, 90.0, -90.0}) {
      const Eigen::Matrix3d turn = Eigen::AngleAxisd(angle * M_PI / 180, axes.col(axis)).toRotationMatrix();
      starts.push_back(kept * Sim3d(1.0, Eigen::Quaterniond(turn), centroid - turn * centroid));
      TurnedPose t;
      t.axis = axis;
      t.angle_deg = angle;
      turned.push_back(t);
    }
  }
  const std::vector<Sim3d> refined = RefineOnBlockPoints(source_points, target_points, starts, voxel);
  for (size_t k = 0; k < turned.size(); ++k) {
    turned[k].target_from_source = refined[k];
    turned[k].agreement = ScoreFieldAgreement(source, target, samples, refined[k], occupancy_scale);
  }
  return turned;
}

void CheckOccupied(Eigen::Index points, const std::string& name, double min_density) {
  if (points < kMinOccupiedPoints) {
    ThrowInputError(name, "occupied cells",
                    fmt::format("at least {} cells with density > {:g} (--min-density) to register, got {}",
                                kMinOccupiedPoints, min_density, points));
  }
}

namespace {

// RegisterBlocks one way: source -> target.
BlockRegistrationResult RegisterOneWay(RegistrationInput& source, RegistrationInput& target,
                                       const BlockRegistrationOptions& options, DregNet* net) {
  if (options.scale == ScaleMode::kFixed) return BlockRegistration(source, target, options, net).Run();
  const bool mixed = source.Kind() != target.Kind();
  Json normalization;
  const Sim3d source_n = NormalizationOf(source, mixed, options, "source", &normalization["source"]);
  const Sim3d target_n = NormalizationOf(target, mixed, options, "target", &normalization["target"]);
  BlockRegistrationResult r;
  {
    const ScopedNormalization s(source, source_n), t(target, target_n);
    r = BlockRegistration(source, target, options, net).Run();
  }
  Denormalize(source_n, target_n, &r);
  for (RegistrationResult& c : r.candidates) Denormalize(source_n, target_n, &c);
  r.source_cloud = source_n.Inverse().TransformPoints(r.source_cloud);
  r.target_cloud = target_n.Inverse().TransformPoints(r.target_cloud);
  r.normalization = normalization;
  // Each input's extent is in range, but not necessarily the ratio of the two.
  CheckScaleInRange(r.target_from_source.scale, InputName(&source, "source"),
                    "scale to " + InputName(&target, "target"));
  return r;
}

// What a result records of the way not kept.
Json OtherWayJson(const BlockRegistrationResult& r) {
  return {{"status", r.status},
          {"status_reason", r.status_reason},
          {"method", r.method},
          {"confidence", r.confidence},
          {"agreeing_candidates", r.agreeing_candidates >= 0 ? Json(r.agreeing_candidates) : Json()},
          {"target_from_source", MatrixToJson(r.target_from_source.ToMatrix())},
          {"scale", r.target_from_source.scale},
          {"seconds", r.seconds}};
}

}  // namespace

BlockRegistrationResult ReversedResult(BlockRegistrationResult r) {
  r.target_from_source = r.target_from_source.Inverse();
  for (RegistrationResult& c : r.candidates) c.target_from_source = c.target_from_source.Inverse();
  std::swap(r.source_cloud, r.target_cloud);
  std::swap(r.source_kind, r.target_kind);
  if (r.normalization.is_object()) {
    r.normalization =
        Json{{"source", r.normalization.value("target", Json())}, {"target", r.normalization.value("source", Json())}};
  }
  r.method += "+reverse";
  r.candidates.at(r.chosen).method = r.method;
  return r;
}

BlockRegistrationResult RegisterEitherWay(const std::function<BlockRegistrationResult(bool reversed)>& one_way,
                                          bool reverse_untrusted) {
  BlockRegistrationResult forward = one_way(false);
  if (forward.status != "untrusted" || !reverse_untrusted) return forward;
  LOG_WARN("untrusted ({}): registering the other way (target onto source)", forward.status_reason);
  BlockRegistrationResult back = one_way(true);
  if (back.status != "registered") {
    forward.reverse = {{"kept", false}, {"other_way", OtherWayJson(back)}};
    forward.status_reason +=
        fmt::format("; the other way (target onto source) is untrusted too (confidence {:.2f})", back.confidence);
    forward.seconds += back.seconds;
    return forward;
  }
  const std::string message = fmt::format(
      "source -> target was untrusted (confidence {:.2f}); the target registered onto the source (confidence {:.2f}) "
      "is kept, inverted",
      forward.confidence, back.confidence);
  LOG_WARN("{}", message);
  BlockRegistrationResult r = ReversedResult(std::move(back));
  r.reverse = {{"kept", true}, {"other_way", OtherWayJson(forward)}};
  r.seconds += forward.seconds;
  // The kept way's warnings are about its own run; the first way's stay readable in other_way.
  r.warnings.insert(r.warnings.begin(), message);
  return r;
}

BlockRegistrationResult RegisterBlocks(RegistrationInput& source, RegistrationInput& target,
                                       const BlockRegistrationOptions& options, DregNet* net) {
  options.Check();
  if (options.UsesNetwork() && !net)
    throw std::invalid_argument("RegisterBlocks: method dreg / auto needs the network");
  return RegisterEitherWay(
      [&](bool reversed) {
        return reversed ? RegisterOneWay(target, source, options, net) : RegisterOneWay(source, target, options, net);
      },
      options.reverse_untrusted);
}

BlockRegistrationResult RegisterBlocks(NerfBlock& source, NerfBlock& target, const BlockRegistrationOptions& options,
                                       DregNet* net) {
  NerfBlockInput s(source), t(target);
  return RegisterBlocks(s, t, options, net);
}

Json BlockRegistrationResult::ToJson() const {
  Json others = Json::array();
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (k != chosen) others.push_back(candidates[k].ToJson());
  }
  Json j = {{"target_from_source", MatrixToJson(target_from_source.ToMatrix())},
            {"scale", target_from_source.scale},
            {"field", field},
            {"confidence", confidence},
            {"method_score", method_score},
            {"agreement", FieldAgreementJson(agreement)},
            {"seconds", seconds},
            {"method", method},
            {"fallback_from", fallback.is_null() ? Json() : fallback},
            {"not_chosen", others},
            {"agreeing_candidates", agreeing_candidates >= 0 ? Json(agreeing_candidates) : Json()},
            {"turn_check", turns},
            {"warnings", warnings},
            {"source_kind", source_kind},
            {"target_kind", target_kind},
            {"status", status},
            {"status_reason", status_reason},
            {"reverse", reverse},
            {"normalization", normalization}};
  j.update(details);
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

}  // namespace nerfreg
