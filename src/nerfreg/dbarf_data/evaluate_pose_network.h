#pragma once
// `dbarf eval-net`'s job: the pose network's relative poses against the datasets' own, per dataset:
// each usable view as target, its view-graph neighbours as sources, the network starting from the
// identity (pose_init "network", the original) or from the scene's cameras; the rotation error and
// the translation-direction error (scale-free), averaged over the pairs, beside the error of the
// start (identity: the true rotation angle). In the learned core: with ground-truth scene cameras
// it needs no SfM, so a GPU machine scores what it trained there.
#include <torch/torch.h>

#include <functional>
#include <string>
#include <vector>

#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct PoseNetworkEvaluationOptions {
  std::vector<std::string> datasets;  // datasets with ground-truth poses
  std::string weights;                // DBARF weights
  std::string pose_init = "network";  // network (from the identity) or cameras
  int num_sources = 5;                // sources per target: view-graph neighbours, best first
  DbarfSceneOptions scene;            // how the views are chosen (scene.cameras)
  torch::Device device = torch::kCPU;
  void Check() const;  // throws InputError naming the flag
};

// Returns {"weights", "pose_init", "sources", "datasets", the means ("start_rotation_deg",
// "rotation_deg", "start_translation_direction_deg", "translation_direction_deg", the network's
// mean normalised target "disparity" (0 = the far bound) and, with ground-truth scene cameras (the
// truth then in the depth range's units), "translation_ratio" = sum |t| / sum |t_true| (a few % is
// the collapsed, static solution)) and "rows" (one per dataset with "dataset", "pairs" and those)}. on_row, if given,
// sees each row as it is done. Throws InputError on bad input (a dataset without ground-truth poses, unreadable
// weights).
Json EvaluatePoseNetwork(const PoseNetworkEvaluationOptions& options,
                         const std::function<void(const Json& row)>& on_row = {});

}  // namespace nerfreg
