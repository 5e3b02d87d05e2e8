#pragma once
// transforms.json as written by NeRF-synthetic (Blender), instant-ngp and nerfstudio:
//  - camera-to-world `transform_matrix` per frame, OpenGL camera axes (converted in
//    geometry/conventions.h);
//  - intrinsics `camera_angle_x` [/ `camera_angle_y`] or `fl_x fl_y cx cy w h` with optional
//    distortion `k1 k2 p1 p2 k3 k4` and nerfstudio's `camera_model` (PINHOLE, OPENCV,
//    OPENCV_FISHEYE), at the top level or per frame (per frame wins);
//  - nerfstudio's `applied_transform`, and dataparser_transforms.json beside the file (kept in
//    Dataset::applied_transform / trained_from_data; poses are read as written);
//  - instant-ngp's `aabb_scale`, `scale`, `offset`, and our `aabb`, `split`, `near`, `far`.
// Image sizes missing from the file are read from the image headers. NeRF-synthetic paths without
// an extension ("./train/r_0") get ".png". Frames are named by their file names, or by their paths
// when two file names repeat (several captures in one file).
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

// kNerf: also camera_angle_x/y and a "split" per frame (NeRF-synthetic and instant-ngp readers);
// kNerfstudio: nerfstudio's fields only, the splits as train_filenames / test_filenames.
enum class TransformsJsonFlavour { kNerf, kNerfstudio };

// Writes atomically: shared intrinsics at the top level, per-frame ones otherwise; camera_model,
// and applied_transform when the dataset has one.
void WriteTransformsJson(const Dataset& dataset, const std::string& path,
                         TransformsJsonFlavour flavour = TransformsJsonFlavour::kNerf);
Json TransformsJsonFromDataset(const Dataset& dataset, TransformsJsonFlavour flavour = TransformsJsonFlavour::kNerf);

// nerfstudio's dataparser_transforms.json ({"transform": [3, 4] rigid, "scale": s}): the map
// p_trained = s * (R p + t) from the transforms.json frame into the trained model's.
// Throws InputError("FILE: FIELD: expected ...").
Sim3d ReadDataparserTransforms(const std::string& path);
void WriteDataparserTransforms(const Sim3d& trained_from_data, const std::string& path);

// Reads every frame's image header and checks its size equals the frame's camera. Throws
// InputError naming the image on a missing file or a size mismatch.
void CheckImagesMatchCameras(const Dataset& dataset);

}  // namespace nerfreg
