#include "nerfreg/pipeline/evaluate_pairs.h"

#include <memory>

#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/pipeline/register_blocks.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

void PairEvaluationOptions::Check() const {
  for (const auto& m : methods)
    if (m != "dreg" && m != "ransac" && m != "fgr" && m != "truth") ThrowInputError("--methods", "", "dreg, ransac, fgr or truth, got " + m);
  for (const auto& r : refines)
    if (r != "none" && r != "icp" && r != "block-icp" && r != "field") ThrowInputError("--refine", "", "none, icp, block-icp or field, got " + r);
  for (const auto& s : dreg_solvers)
    if (s != "ransac" && s != "procrustes") ThrowInputError("--dreg-solver", "", "ransac or procrustes, got " + s);
}

std::vector<PairEvaluation> EvaluatePairs(const std::vector<PairRecord>& pairs, const PairEvaluationOptions& options,
                                          DregNet* net, const std::function<void(const PairEvaluation&)>& on_row) {
  options.Check();
  std::vector<PairEvaluation> rows;
  bool warned_field = false;
  for (const auto& p : pairs) {
    const RegGrid src = LoadRegGrid(p.source), tgt = LoadRegGrid(p.target);
    // --refine field needs the blocks themselves: real pairs keep block_K.ckpt beside block_K.grid.
    std::unique_ptr<NerfBlock> src_block, tgt_block;
    std::unique_ptr<OccupiedPoints> occupied;  // block ICP's points, extracted once per pair
    for (const auto& rf : options.refines) {
      if ((rf != "field" && rf != "block-icp") || src_block) continue;
      if (p.kind != "nerf") {
        if (!warned_field) LOG_WARN("--refine {}: skipped on synthesised pairs (no NeRF blocks), e.g. {}", rf, p.name);
        warned_field = true;
        continue;
      }
      auto ckpt = [](const std::string& grid) { return grid.substr(0, grid.size() - std::string(".grid").size()) + ".ckpt"; };
      src_block = std::make_unique<NerfBlock>(LoadNerfBlock(ckpt(p.source), nullptr, options.device));
      tgt_block = std::make_unique<NerfBlock>(LoadNerfBlock(ckpt(p.target), nullptr, options.device));
      occupied = std::make_unique<OccupiedPoints>(*src_block, *tgt_block, BlockRegistrationOptions{}.min_density, 0);
    }
    for (const auto& m : options.methods) {
      for (const auto& solver : m == "dreg" ? options.dreg_solvers : std::vector<std::string>{"ransac"})
      for (const int passes : m == "dreg" ? options.dreg_passes : std::vector<int>{1})
      for (const auto& rf : options.refines) {
        if ((rf == "field" || rf == "block-icp") && !src_block) continue;
        GridRegistrationOptions o = options.base;  // the ICP's points, distance, half-turns and the voxel
        o.method = m;
        o.dreg_solver = solver;
        o.dreg_passes = passes;
        o.icp = rf != "none";
        GridRegistrationResult r;
        if (m == "truth") {
          // The refinement floor: each refinement started at the ground truth; where it ends is
          // what the two blocks' own disagreement costs, whatever found the coarse pose.
          Timer timer;
          r.method = "truth";
          r.target_from_source = p.target_from_source;
          r.confidence = 1;
          if (o.icp) {
            o.method = options.base.method;  // the coarse method's name is all RefineGridPose checks; none runs
            const std::string name = o.Name();  // "dreg+icp[mask]...": the ICP's part names the row
            o.flips = false;                    // no half-turns of the truth
            r.target_from_source = RefineGridPose(src, tgt, p.target_from_source, o);
            r.method = "truth" + name.substr(name.find("+icp"));
          }
          r.seconds = timer.Seconds();
        } else {
          r = RegisterGrids(src, tgt, o, net);
        }
        if (rf == "block-icp" || rf == "field") {  // as reg register: ICP on the grids, then on the blocks
          Json block_icp;
          r.target_from_source = RefineOnBlockPoints(occupied->Source(), occupied->Target(),
                                                     Sim3d::FromMatrix(r.target_from_source, 1e-3), options.base.voxel, &block_icp)
                                     .ToMatrix();
          r.seconds += block_icp["seconds"].get<double>();
          r.method += "+block";
        }
        if (rf == "field") {
          Json field;
          r.target_from_source = RefineOnFields(*src_block, *tgt_block, PointsToEigen(src.MaskedXyz()), PointsToEigen(tgt.MaskedXyz()),
                                                Sim3d::FromMatrix(r.target_from_source, 1e-3), options.field, src.CellSize(),
                                                &field, &src, &tgt)
                                     .ToMatrix();
          r.seconds += field["seconds"].get<double>();
          r.method += "+field";
        }
        PairEvaluation row;
        row.pair = p.name;
        row.method = r.method;
        row.seconds = r.seconds;
        row.confidence = r.confidence;
        row.overlap = p.overlap;
        const Sim3d est = Sim3d::FromMatrix(r.target_from_source, 1e-3), truth = Sim3d::FromMatrix(p.target_from_source, 1e-3);
        row.rotation_deg = RotationErrorDeg(est.rotation, truth.rotation);
        row.translation = TranslationError(est.translation, truth.translation);
        rows.push_back(row);
        if (on_row) on_row(row);
      }
    }
  }
  return rows;
}

}  // namespace nerfreg
