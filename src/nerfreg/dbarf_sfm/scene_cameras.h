// The SfM's cameras for DBARF's scenes (dbarf_data/dbarf_scene.h's DbarfCameraEstimator): a
// dataset's poses are ground truth, kept for evaluation only, and the cameras, depth range and
// view graph used for training and rendering are estimated from its images (sfm/global_sfm.h),
// optionally kept in a folder between runs. The edge between DBARF's scenes and the SfM layers.
#pragma once

#include <string>

#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/sfm/global_sfm.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct SfmSceneCamerasOptions {
  SfmOptions sfm;
  // Folder where cameras estimated from the images are kept between runs (empty: not kept). A
  // scene whose images, intrinsics and max_width are unchanged reuses its entry instead of running
  // the SfM again, which is what makes resuming a training run on hundreds of scenes start in
  // seconds rather than tens of minutes. An entry records neither the SfM options nor the code
  // version beyond kSfmCacheVersion: clear the folder after changing either.
  std::string cache_dir;
  void Check() const;  // throws InputError naming the option
};

// Bumped whenever what an SfM cache entry holds, or how the SfM result it stores is computed by
// default, changes.
inline constexpr int kSfmCacheVersion = 1;

// The estimator DbarfSceneOptions::estimate_cameras takes: the SfM, through the cache folder.
DbarfCameraEstimator SfmCameraEstimator(const SfmSceneCamerasOptions& options);

// Depth range of triangulated points seen by posed cameras: the 2nd / 98th percentiles of their
// camera depths, widened by 0.7 / 1.4. Throws InputError (source) with fewer than 10 depths.
void DepthRangeFromPoints(const SfmResult& sfm, const std::string& source, double* near, double* far);

// The view graph as written into transforms.json by dbarf poses: [[name_i, name_j, inliers], ...].
Json ViewGraphToJson(const ViewGraph& graph);

}  // namespace nerfreg
