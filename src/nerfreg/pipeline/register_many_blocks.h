#pragma once
// Many NeRF blocks into one frame (block 0's), `reg register-many`'s job: every pair registered
// by reg register's chain (registration/registration_chain.h), FPFH + RANSAC + ICP on the blocks'
// occupied points (then, with kField, refined on the two fields); pairs whose fitness reaches
// min_confidence become edges of a pose graph, solved with a robust loss from a cycle-consistent
// spanning tree; edges that disagree with their loops are dropped and named (a block of another
// object, a wrong registration). With ScaleMode::kFree (the default) the inputs may be in
// different units: each is normalised by its own occupied extent once (as reg register does,
// registration/scale_normalization.h), every pair's chain estimates the scale, and the pose graph
// is a Sim(3) graph solved in the normalised frames (so its thresholds mean the same for every
// input); the per-block similarities are then carried back to the inputs' own units.
#include <map>
#include <string>
#include <vector>

#include "nerfreg/data/splat_ply.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/splat_field.h"
#include "nerfreg/registration/registration_options.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct ManyBlockRegistrationOptions {
  double min_density = BlockRegistrationOptions{}.min_density;  // --min-density
  double voxel = 0.05;                                          // --voxel
  int max_points = 5000;                                        // --max-points
  double min_confidence = 0.3;  // --min-confidence: pairs below this RANSAC fitness are not edges
  unsigned seed = 0;            // --seed
  RegistrationRefinement refine = RegistrationRefinement::kField;  // --refine: kIcp or kField
  // --scale: kFree, each block's scale estimated (a Sim(3) graph); kFixed, a rigid graph of blocks
  // that share a unit (as before Sim(3)).
  ScaleMode scale = ScaleMode::kFree;
  SplatFieldOptions splats;  // --splat-density-scale, --splat-blur: splat PLY inputs as fields
  // --dataparser K=FILE: input K is in a nerfstudio run's trained frame; capture_from_file (the
  // inverse of its dataparser_transforms.json) moves it into its capture's frame on load
  // (LoadRegistrationInput), so every pose and merged output is in the capture's units.
  std::map<int, Sim3d> capture_from_file;
  void Check() const;  // throws InputError naming the flag
  Json ToJson() const;
};

struct ManyBlockRegistrationResult {
  // {world_from_block: [4x4...], scale: [...], connected, edges: [{source, target,
  // target_from_source, scale, confidence, used, field, inlier, rotation_residual_deg,
  // translation_residual, scale_residual, dropped}], normalization, seconds, blocks}, as reg
  // register-many writes it. Poses in the inputs' own units; the residuals in the graph's
  // (normalised with kFree) units.
  Json json;
  int used_edges = 0;  // pairs kept in the graph
  int pairs = 0;       // pairs tried
  // As in json, one per input: x_in_block_0 = world_from_block[k] * x_in_k, both in the inputs'
  // capture frames (options.capture_from_file).
  std::vector<Sim3d> world_from_block;
  std::vector<Sim3d> capture_from_file;  // one per input: options.capture_from_file, else the identity
  std::vector<std::string> warnings;
};

// `paths`: block checkpoints or splat PLYs (the first defines the world frame), loaded here.
ManyBlockRegistrationResult RegisterManyBlocks(const std::vector<std::string>& paths,
                                               const ManyBlockRegistrationOptions& options);

// Every splat PLY among `paths` moved into the world frame (result.world_from_block after
// result.capture_from_file) and merged
// into one splat set (the highest SH degree of them; lower-degree splats get zero coefficients;
// extra properties dropped unless every input has the same ones). Throws InputError when no
// input is a splat PLY.
Splats MergeSplatsInWorld(const std::vector<std::string>& paths, const ManyBlockRegistrationResult& result);

// Every block checkpoint's cameras among `paths` moved into the world frame (MoveNerfBlock: centres
// and axes by result.world_from_block, near / far bounds scaled) in one transforms.json, written
// atomically to `out`: image paths absolute where the checkpoint records its images' folder; each
// frame also names its input ("block": index, "block_path"). An image several blocks were trained
// on is listed once, with the first block's camera, the blocks that have it ("blocks") and how far
// their cameras lie from that one ("spread": largest centre distance, world units, and rotation,
// degrees): how well the registration agrees with the blocks' own cameras. Splat PLYs carry no
// cameras: `splat_cameras` gives input K's (a transforms.json, COLMAP model or LLFF scene in the
// capture's frame, as ReadCameras reads it), else it is skipped. Returns the number of frames;
// throws InputError when no input has any.
int WriteMergedCameras(const std::vector<std::string>& paths, const ManyBlockRegistrationResult& result,
                       const std::string& out, const std::map<int, std::string>& splat_cameras = {});

}  // namespace nerfreg
