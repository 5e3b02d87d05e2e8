#pragma once
// A Sim(3) applied to what the data layer reads: the pieces of `reg apply` that need no torch and
// no Open3D. Each takes new_from_old (x_new = s R x_old + t) and returns the moved copy; nothing
// is resampled, and applying new_from_old.Inverse() to the result gives the input back to
// rounding (tests: sim3_apply_test.cc, tests/apply_cli_test.cc).
#include <string>

#include "nerfreg/data/colmap.h"
#include "nerfreg/data/dataset.h"
#include "nerfreg/data/npy.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// Splats: centres x -> s R x + t; normals rotated; log scales + log s; rotations q -> q_R q (their
// norm kept: files store them unnormalised); the SH coefficients of degrees 1-3 rotated per channel
// (geometry/sh_rotation.h), so each splat shows the same colour from the same side of it. The DC
// term, the opacities and the extra properties are unchanged.
Splats TransformSplats(const Splats& splats, const Sim3d& new_from_old);

// A parsed transforms.json (NeRF-synthetic, instant-ngp or nerfstudio), edited in place so every
// key we do not know survives: each frame's camera-to-world transform_matrix moved (its centre by
// the Sim(3), its axes by R); per-frame `near` / `far` times s; our `aabb` replaced by the box
// around the moved one (it grows under a rotation that is not a multiple of 90 deg); instant-ngp's
// `scale` / `offset` (when either is there) set so ngp's unit cube holds the same part of the
// scene (scale / s, the cube's centre moved by the Sim(3)); nerfstudio's `applied_transform`
// (when there) composed with the Sim(3) (it maps the COLMAP frame into this file's). Throws
// InputError naming `source` and the field on a malformed frame.
Json TransformTransformsJson(const Json& json, const Sim3d& new_from_old, const std::string& source);

// nerfstudio's dataparser_transforms.json beside a moved transforms.json: the trained model's
// frame stays where it was, so trained_from_new = trained_from_old * old_from_new.
Sim3d TransformDataparser(const Sim3d& trained_from_old, const Sim3d& new_from_old);

// A Dataset's cameras moved in place: each frame's cam_from_world (Sim3d::TransformCamera: a rigid
// camera, its centre moved by the Sim(3)), near / far times s, the aabb replaced by the box around
// the moved one, nerfstudio's applied_transform composed with the Sim(3), and trained_from_data
// kept pointing at the same trained frame.
void MoveCameras(Dataset* cameras, const Sim3d& new_from_old);

// A COLMAP model: images' cam_from_world moved (Sim3d::TransformCamera: a rigid camera, its
// centre moved by the Sim(3)), points3D moved; cameras, tracks and colours unchanged.
ColmapModel TransformColmapModel(const ColmapModel& model, const Sim3d& new_from_old);

// LLFF poses_bounds.npy ([N, 17]: a 3x5 [R | centre | hwf] camera-to-world per row, then near and
// far): R and the centres moved, hwf kept, the bounds times s. Throws InputError naming `source`
// when the array is not [N, 17].
NpyArray TransformLlffPoses(const NpyArray& poses_bounds, const Sim3d& new_from_old, const std::string& source);

}  // namespace nerfreg
