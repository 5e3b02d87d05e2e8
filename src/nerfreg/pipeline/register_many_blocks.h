#pragma once
// Many NeRF blocks into one frame (block 0's), `reg register-many`'s job: every pair registered
// by reg register's job (RegisterBlocks, registration/register_blocks.h: the same candidates, the
// choice on the fields, the turn check and the judgement, with the same options); the pairs it
// calls registered become edges of a pose graph, weighted by their confidence and solved with a
// robust loss from a cycle-consistent spanning tree; an untrusted pair is no edge, and edges that
// disagree with their loops are dropped and named (a block of another object, a wrong
// registration). With ScaleMode::kFree (the default) the inputs may be in different units: each
// pair's job estimates the scale, and the pose graph is a Sim(3) graph solved in frames where each
// input is normalised by its own occupied extent (registration/scale_normalization.h, so its
// thresholds mean the same for every input); the per-block similarities are then carried back to
// the inputs' own units.
#include <map>
#include <string>
#include <vector>

#include "nerfreg/data/splat_ply.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/splat_field.h"
#include "nerfreg/registration/registration_options.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct ManyBlockRegistrationOptions {
  // Each pair's registration: reg register's options and flags (method, refine, scale, ...). With
  // scale kFixed the graph is rigid: blocks that share a unit.
  BlockRegistrationOptions pair;
  // --dataparser K=FILE: input K is in a nerfstudio run's trained frame; capture_from_file (the
  // inverse of its dataparser_transforms.json) moves it into its capture's frame on load
  // (LoadRegistrationInput), so every pose and merged output is in the capture's units.
  std::map<int, Sim3d> capture_from_file;
  void Check() const;  // throws InputError naming the flag
  Json ToJson() const;
};

struct ManyBlockRegistrationResult {
  // {status ("registered", or "untrusted" when an input is not connected), status_reason,
  // untrusted_pairs, world_from_block: [4x4...], scale: [...], connected, edges: [{source, target,
  // target_from_source, scale, confidence, method, status, status_reason, turn_margin, turn_colour_margin,
  // agreeing_candidates, seconds, used, field, inlier, rotation_residual_deg, translation_residual,
  // scale_residual, dropped}], normalization, seconds, blocks}, as reg register-many writes it.
  // Poses in the inputs' own units; the residuals in the graph's (normalised with kFree) units.
  Json json;
  int used_edges = 0;   // pairs kept in the graph
  int pairs = 0;        // pairs tried
  int untrusted = 0;    // pairs whose registration was untrusted (no edge)
  int unconnected = 0;  // inputs no kept edge links to input 0 (left at the identity)
  // As in json, one per input: x_in_block_0 = world_from_block[k] * x_in_k, both in the inputs'
  // capture frames (options.capture_from_file).
  std::vector<Sim3d> world_from_block;
  std::vector<Sim3d> capture_from_file;  // one per input: options.capture_from_file, else the identity
  std::vector<bool> connected;           // one per input: linked to input 0 by kept edges (else not registered)
  std::vector<std::string> warnings;
};

// `paths`: block checkpoints or splat PLYs (the first defines the world frame), loaded here.
// `net`: needed when options.pair.UsesNetwork() (std::invalid_argument when null), as RegisterBlocks.
ManyBlockRegistrationResult RegisterManyBlocks(const std::vector<std::string>& paths,
                                               const ManyBlockRegistrationOptions& options, DregNet* net);

// Every registered splat PLY among `paths` (result.connected) moved into the world frame
// (result.world_from_block after result.capture_from_file) and merged
// into one splat set (the highest SH degree of them; lower-degree splats get zero coefficients;
// extra properties dropped unless every input has the same ones). Throws InputError when no
// input is a splat PLY.
Splats MergeSplatsInWorld(const std::vector<std::string>& paths, const ManyBlockRegistrationResult& result);

// Every registered block checkpoint's cameras among `paths` (result.connected) moved into the world frame
// (MoveNerfBlock: centres and axes by result.world_from_block, near / far bounds scaled) in one transforms.json,
// written atomically to `out`: image paths absolute where the checkpoint records its images' folder; each frame also
// names its input ("block": index, "block_path"). An image several blocks were trained on is listed once, with the
// first block's camera, the blocks that have it ("blocks") and how far their cameras lie from that one ("spread":
// largest centre distance, world units, and rotation, degrees): how well the registration agrees with the blocks' own
// cameras. Splat PLYs carry no cameras: `splat_cameras` gives input K's (a transforms.json, COLMAP model or LLFF scene
// in the capture's frame, as ReadCameras reads it), else it is skipped. Returns the number of frames; throws InputError
// when no input has any.
int WriteMergedCameras(const std::vector<std::string>& paths, const ManyBlockRegistrationResult& result,
                       const std::string& out, const std::map<int, std::string>& splat_cameras = {});

}  // namespace nerfreg
