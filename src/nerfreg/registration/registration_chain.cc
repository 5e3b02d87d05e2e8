#include "nerfreg/registration/registration_chain.h"

#include <cmath>
#include <stdexcept>

#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/registration/grid_registration.h"
#include "nerfreg/registration/point_registration.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

RegistrationPair::RegistrationPair(RegistrationInput& source, RegistrationInput& target,
                                   const BlockRegistrationOptions& options)
    : source_(&source),
      target_(&target),
      grid_options_(options.grid),
      min_density_(options.min_density),
      seed_(options.seed) {}

RegistrationPair::RegistrationPair(NerfBlock& source, NerfBlock& target, const BlockRegistrationOptions& options)
    : owned_source_(std::make_unique<NerfBlockInput>(source)),
      owned_target_(std::make_unique<NerfBlockInput>(target)),
      source_(owned_source_.get()),
      target_(owned_target_.get()),
      grid_options_(options.grid),
      min_density_(options.min_density),
      seed_(options.seed) {}

RegistrationPair::RegistrationPair(RegGrid source_grid, RegGrid target_grid, RegistrationInput* source,
                                   RegistrationInput* target, const BlockRegistrationOptions& options)
    : source_(source),
      target_(target),
      grid_options_(options.grid),
      min_density_(options.min_density),
      seed_(options.seed),
      grids_ready_(true),
      grids_given_(true),
      source_grid_(std::move(source_grid)),
      target_grid_(std::move(target_grid)) {
  source_masked_ = PointsToEigen(source_grid_.MaskedXyz());
  target_masked_ = PointsToEigen(target_grid_.MaskedXyz());
}

RegistrationPair::RegistrationPair(Eigen::Matrix3Xd source_points, Eigen::Matrix3Xd target_points,
                                   RegistrationInput* source, RegistrationInput* target,
                                   const BlockRegistrationOptions& options)
    : source_(source),
      target_(target),
      grid_options_(options.grid),
      min_density_(options.min_density),
      seed_(options.seed),
      points_ready_(true),
      source_points_(std::move(source_points)),
      target_points_(std::move(target_points)) {}

void RegistrationPair::ExtractGrids() {
  if (grids_ready_) return;
  if (!HasInputs()) throw std::logic_error("RegistrationPair: no inputs to extract grids from");
  Timer timer;
  GridExtractionOptions go = grid_options_;
  go.seed = seed_;
  source_grid_ = source_->ExtractGrid(go);
  target_grid_ = target_->ExtractGrid(go);
  grid_seconds_ = timer.Seconds();
  source_masked_ = PointsToEigen(source_grid_.MaskedXyz());
  target_masked_ = PointsToEigen(target_grid_.MaskedXyz());
  grids_ready_ = true;
}

void RegistrationPair::ExtractPoints() {
  if (points_ready_) return;
  if (!HasInputs()) throw std::logic_error("RegistrationPair: no inputs to extract occupied points from");
  Timer timer;
  // A block against splats: the block's solid as a shell, as the splats are (else ICP settles the
  // capture's surface inside the block's solid).
  const bool mixed = source_->Kind() != target_->Kind();
  source_points_ = source_->OccupiedPoints(min_density_, seed_, mixed);
  target_points_ = target_->OccupiedPoints(min_density_, seed_, mixed);
  points_seconds_ = timer.Seconds();
  points_ready_ = true;
}

const RegGrid& RegistrationPair::SourceGrid() {
  ExtractGrids();
  return source_grid_;
}

const RegGrid& RegistrationPair::TargetGrid() {
  ExtractGrids();
  return target_grid_;
}

const Eigen::Matrix3Xd& RegistrationPair::SourcePoints() {
  ExtractPoints();
  return source_points_;
}

const Eigen::Matrix3Xd& RegistrationPair::TargetPoints() {
  ExtractPoints();
  return target_points_;
}

const Eigen::Matrix3Xd& RegistrationPair::SourceCloud(RegistrationCloud cloud) {
  if (cloud == RegistrationCloud::kOccupied) return SourcePoints();
  ExtractGrids();
  return source_masked_;
}

const Eigen::Matrix3Xd& RegistrationPair::TargetCloud(RegistrationCloud cloud) {
  if (cloud == RegistrationCloud::kOccupied) return TargetPoints();
  ExtractGrids();
  return target_masked_;
}

DensityField RegistrationPair::SourceField() {
  if (!source_) throw std::logic_error("RegistrationPair: no source input for its field");
  return source_->Field();
}

DensityField RegistrationPair::TargetField() {
  if (!target_) throw std::logic_error("RegistrationPair: no target input for its field");
  return target_->Field();
}

double RegistrationPair::GridCell() const {
  return grids_given_ ? source_grid_.CellSize() : grid_options_.side / grid_options_.resolution;
}

RegistrationResult RegisterCoarse(RegistrationPair& pair, RegistrationMethod method, RegistrationCloud cloud,
                                  const BlockRegistrationOptions& options, DregNet* net) {
  if (cloud == RegistrationCloud::kGridMask) {
    return RegisterGrids(pair.SourceGrid(), pair.TargetGrid(), GridOptionsFor(options, method), net);
  }
  return RegisterPoints(pair.SourcePoints(), pair.TargetPoints(), method, options);
}

void RefineOnBlockPoints(RegistrationPair& pair, const BlockRegistrationOptions& options, RegistrationResult* r) {
  Json& record = r->details["block_icp"];
  r->target_from_source = RefineOnBlockPoints(pair.SourcePoints(), pair.TargetPoints(), r->target_from_source,
                                              options.voxel, &record, options.scale == ScaleMode::kFree);
  r->seconds += record["seconds"].get<double>();
  r->method += "+block";
}

namespace {

// The pair's two fields; with options.field.overlap_only and the pair's grids, each field's `seen`
// is its grid's mask.
void PairFields(RegistrationPair& pair, const BlockRegistrationOptions& options, DensityField* source,
                DensityField* target) {
  *source = pair.SourceField();
  *target = pair.TargetField();
  if (options.field.overlap_only && pair.HasGrids()) {
    source->seen = SeenFromGrid(pair.SourceGrid());
    target->seen = SeenFromGrid(pair.TargetGrid());
  }
}

// The fields aligned coarse to fine from `start`: samples spread kFieldCoarseSpread cells wide
// (`coarse` records it), then one cell (`fine`), around the result's cloud.
Sim3d RefineOnFieldsCoarseToFine(RegistrationPair& pair, const DensityField& source, const DensityField& target,
                                 RegistrationCloud cloud, const Sim3d& start, const FieldAlignmentOptions& field,
                                 Json* coarse, Json* fine) {
  const Eigen::Matrix3Xd &src = pair.SourceCloud(cloud), &tgt = pair.TargetCloud(cloud);
  const Sim3d c = RefineOnFields(source, target, src, tgt, start, field, kFieldCoarseSpread * pair.GridCell(), coarse);
  return RefineOnFields(source, target, src, tgt, c, field, pair.GridCell(), fine);
}

}  // namespace

void RefineOnFields(RegistrationPair& pair, const BlockRegistrationOptions& options, RegistrationResult* r) {
  DensityField source, target;
  PairFields(pair, options, &source, &target);
  FieldAlignmentOptions field = options.field;
  field.estimate_scale = options.scale == ScaleMode::kFree;
  if (field.estimate_scale) {
    Json coarse;
    r->target_from_source =
        RefineOnFieldsCoarseToFine(pair, source, target, r->cloud, r->target_from_source, field, &coarse, &r->field);
    r->field["coarse"] = coarse;
    r->seconds += coarse["seconds"].get<double>();
  } else {
    r->target_from_source = RefineOnFields(source, target, pair.SourceCloud(r->cloud), pair.TargetCloud(r->cloud),
                                           r->target_from_source, field, pair.GridCell(), &r->field);
  }
  r->seconds += r->field["seconds"].get<double>();
  r->method += "+field";
}

void PolishWithScaleHeld(RegistrationPair& pair, const BlockRegistrationOptions& options, RegistrationResult* r) {
  if (options.scale != ScaleMode::kFree || options.refine != RegistrationRefinement::kField) return;
  if (pair.SourceCloud(r->cloud).cols() < 3 || pair.TargetCloud(r->cloud).cols() < 3) return;
  Json polish = {{"before", MatrixToJson(r->target_from_source.ToMatrix())}};
  // Block ICP rigid, on the source scaled by the result's scale.
  const Sim3d pose = RefineOnBlockPoints(pair.SourcePoints(), pair.TargetPoints(), r->target_from_source, options.voxel,
                                         &polish["block_icp"], false);
  DensityField source, target;
  PairFields(pair, options, &source, &target);
  FieldAlignmentOptions field = options.field;
  field.estimate_scale = false;
  const Sim3d refined = RefineOnFieldsCoarseToFine(pair, source, target, r->cloud, pose, field, &polish["field_coarse"],
                                                   &polish["field"]);
  const Json& f = polish["field"];
  const bool kept = f["iterations"].get<int>() > 0 && f["final_cost"].get<double>() <= f["initial_cost"].get<double>();
  polish["kept"] = kept;
  r->seconds += polish["block_icp"]["seconds"].get<double>() + polish["field_coarse"]["seconds"].get<double>() +
                f["seconds"].get<double>();
  if (kept) {
    r->target_from_source = refined;
    r->method += "+polish";
  }
  r->details["polish"] = polish;
}

void ContinueChain(RegistrationPair& pair, const BlockRegistrationOptions& options, RegistrationResult* r) {
  if (r->cloud == RegistrationCloud::kGridMask && options.refine != RegistrationRefinement::kNone &&
      options.block_icp) {
    RefineOnBlockPoints(pair, options, r);
  }
  if (options.refine == RegistrationRefinement::kField) {
    RefineOnFields(pair, options, r);
    PolishWithScaleHeld(pair, options, r);
  }
}

RegistrationResult RunChain(RegistrationPair& pair, RegistrationMethod method, RegistrationCloud cloud,
                            const BlockRegistrationOptions& options, DregNet* net) {
  RegistrationResult r = RegisterCoarse(pair, method, cloud, options, net);
  ContinueChain(pair, options, &r);
  return r;
}

namespace {

// Whether a field refinement moved the scale from `start` to `refined` by more than
// kMaxFieldScaleChange.
bool ScaleMovedFar(double start, double refined) {
  return std::abs(std::log(refined / start)) > std::log(kMaxFieldScaleChange);
}

}  // namespace

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
  if (options.estimate_scale) (*json)["scale"] = f.scale;
  if (!ScaleMovedFar(start.scale, f.scale))
    return Sim3d(f.scale, f.target_from_source.rotation, f.target_from_source.translation);
  // The scale moved far: kept only on the refinement's evidence (AcceptFieldScaleChange).
  FieldAlignmentResult again;
  if (f.iterations > 0 && f.final_cost <= (1 - kMinFieldCostDrop) * f.initial_cost) {
    again = AlignFields(src_field, tgt_field, src_points, tgt_points, f.target_from_source, options, f.scale);
  }
  const bool accepted = AcceptFieldScaleChange(start.scale, f, again);
  (*json)["scale_check"] = {
      {"start_scale", start.scale},
      {"refined_scale", f.scale},
      {"cost_drop", f.initial_cost > 0 ? 1 - f.final_cost / f.initial_cost : 0.0},
      {"again_iterations", again.iterations},
      {"again_scale", again.scale},
      {"again_turn_deg",
       again.iterations > 0 ? RotationErrorDeg(again.target_from_source.rotation, f.target_from_source.rotation) : 0.0},
      {"accepted", accepted}};
  (*json)["seconds"] = f.seconds + again.seconds;
  if (!accepted) {
    LOG_WARN(
        "field refinement: the scale moved from {:.4g} to {:.4g} without the evidence to keep it; pose left as it was",
        start.scale, f.scale);
    (*json)["rejected"] = true;
    return start;
  }
  (*json)["scale"] = again.scale;
  (*json)["final_cost"] = again.final_cost;
  return Sim3d(again.scale, again.target_from_source.rotation, again.target_from_source.translation);
}

bool AcceptFieldScaleChange(double start_scale, const FieldAlignmentResult& first, const FieldAlignmentResult& again) {
  if (!ScaleMovedFar(start_scale, first.scale)) return true;
  if (first.iterations == 0 || !(first.final_cost <= (1 - kMinFieldCostDrop) * first.initial_cost)) return false;
  if (again.iterations == 0) return false;  // the second refinement did not run: nothing says it settled
  return std::abs(std::log(again.scale / first.scale)) < std::log(kMaxFieldRestartScaleChange) &&
         RotationErrorDeg(again.target_from_source.rotation, first.target_from_source.rotation) <
             kMaxFieldRestartTurnDeg;
}

}  // namespace nerfreg
