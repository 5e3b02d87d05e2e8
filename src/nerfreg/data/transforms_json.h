#pragma once
// transforms.json as written by NeRF-synthetic (Blender), instant-ngp and nerfstudio:
//  - camera-to-world `transform_matrix` per frame, OpenGL camera axes (converted in
//    geometry/conventions.h);
//  - intrinsics `camera_angle_x` [/ `camera_angle_y`] or `fl_x fl_y cx cy w h` with optional
//    OpenCV distortion `k1 k2 p1 p2`, at the top level or per frame (per frame wins);
//  - instant-ngp's `aabb_scale`, `scale`, `offset`, and our `aabb`, `split`, `near`, `far`.
// Image sizes missing from the file are read from the image headers. NeRF-synthetic paths without
// an extension ("./train/r_0") get ".png".
#include <string>

#include "nerfreg/data/dataset.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// Reads a transforms.json; image paths are relative to its directory. A file named
// transforms_test.json / transforms_val.json gives its frames that split unless they say
// otherwise. Throws InputError("FILE: FIELD: expected ...").
Dataset ReadTransformsJson(const std::string& path);
// The same from parsed JSON; `source` names it in errors, `root` is where image paths start.
Dataset DatasetFromTransformsJson(const Json& json, const std::string& source, const std::string& root);

// Writes atomically: shared intrinsics at the top level, per-frame ones otherwise.
void WriteTransformsJson(const Dataset& dataset, const std::string& path);
Json TransformsJsonFromDataset(const Dataset& dataset);

// Reads every frame's image header and checks its size equals the frame's camera. Throws
// InputError naming the image on a missing file or a size mismatch.
void CheckImagesMatchCameras(const Dataset& dataset);

}  // namespace nerfreg
