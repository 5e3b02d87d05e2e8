#pragma once
// `reg apply T.json INPUT --out OUTPUT`: the pose `reg register` found, applied to the files a user
// has, so they need not move them by hand. T.json's target_from_source (or its inverse) moves
// INPUT, whose kind is detected:
//   splat PLY (data/splat_ply.h: IsSplatPly)   centres, rotations, scales, SH degrees 1-3
//   point-cloud or mesh PLY                    vertices and normals (Open3D; render/ply_transform.h)
//   transforms.json (or its folder)            camera poses, bounds, ngp scale / offset, nerfstudio's
//                                              applied_transform and dataparser_transforms.json
//   COLMAP model folder (text or binary)       image poses and 3D points, written in the same encoding
//   LLFF poses_bounds.npy (or its folder)      poses and near / far bounds
//   NeRF block checkpoint (anything else)      its frame (NerfBlock::world_from_field) and cameras:
//                                              the field is not resampled
// The pure transforms are in data/sim3_apply.h and nerf/nerf_block.h (MoveNerfBlock).
// Outputs follow docs/errors.md: checked before any work (an existing one needs force, and an
// input is never replaced, even with force), written atomically (a COLMAP folder as an OutputDir).
#include <string>
#include <vector>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

enum class ApplyInputKind { kSplats, kPly, kTransformsJson, kColmap, kLlff, kNerfBlock };
std::string ApplyInputKindName(ApplyInputKind kind);  // "splats", "ply", "transforms.json", ...

struct ApplyTransformOptions {
  std::string transform;  // T.json: "target_from_source" (a 4x4 similarity)
  std::string input;
  std::string output;    // a file; a folder for a COLMAP model
  bool inverse = false;  // --inverse: apply source_from_target instead
  bool force = false;    // --force: replace an existing output (never an input)
  void Check() const;    // throws InputError naming the option
};

struct ApplyTransformResult {
  ApplyInputKind kind = ApplyInputKind::kSplats;
  Sim3d applied;                     // new_from_old, as applied
  std::vector<std::string> written;  // every file or folder written
  std::int64_t items = 0;            // splats, vertices, cameras, images or frames moved
};

// T.json's target_from_source; InputError naming the file when missing or not a similarity.
Sim3d ReadTargetFromSource(const std::string& path);

// What `input` is (InputError naming it when none of the above).
ApplyInputKind DetectApplyInput(const std::string& input);

ApplyTransformResult ApplyTransformFile(const ApplyTransformOptions& options);

}  // namespace nerfreg
