// The flags of how DBARF's commands get a dataset's cameras from its images: the SfM, cached with
// --sfm-cache, in the full build; none in the learned core's, which has no SfM (there a dataset
// whose poses are ground truth needs --scene-cameras ground-truth).
#pragma once

#include <CLI/CLI.hpp>

#include "nerfreg/dbarf_data/dbarf_scene.h"
#ifndef NERFREG_LEARNED_CORE_ONLY
#include "nerfreg/dbarf_sfm/scene_cameras.h"
#endif

namespace nerfreg {

struct SceneCameraFlags {
#ifndef NERFREG_LEARNED_CORE_ONLY
  SfmSceneCamerasOptions sfm;
#endif
  void AddOptions(CLI::App& app) {
#ifndef NERFREG_LEARNED_CORE_ONLY
    app.add_option("--sfm-cache", sfm.cache_dir,
                   "Keep the cameras estimated from each scene's images in this folder and reuse them (clear it after "
                   "changing the SfM)");
#else
    (void)app;
#endif
  }
  DbarfCameraEstimator Estimator() const {
#ifndef NERFREG_LEARNED_CORE_ONLY
    return SfmCameraEstimator(sfm);
#else
    return {};
#endif
  }
};

}  // namespace nerfreg
