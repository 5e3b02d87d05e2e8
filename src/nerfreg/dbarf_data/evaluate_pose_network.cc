#include "nerfreg/dbarf_data/evaluate_pose_network.h"

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/util/error.h"

namespace nerfreg {

void PoseNetworkEvaluationOptions::Check() const {
  if (datasets.empty()) throw InputError("datasets: expected at least one dataset");
  if (num_sources < 1) throw InputError("--sources: expected >= 1, got " + std::to_string(num_sources));
  if (pose_init != "network" && pose_init != "cameras") {
    throw InputError("--pose-init: expected network or cameras, got " + pose_init);
  }
  scene.Check();
}

Json EvaluatePoseNetwork(const PoseNetworkEvaluationOptions& o, const std::function<void(const Json& row)>& on_row) {
  o.Check();
  DbarfModel model = LoadDbarfWeights(o.weights);
  model.To(o.device);
  Json rows = Json::array();
  double sum_rot = 0, sum_dir = 0, sum_start_rot = 0, sum_start_dir = 0, sum_ratio = 0, sum_disparity = 0;
  // The truth is in the depth range's units only where the scene's cameras are the dataset's own.
  const bool same_units = o.scene.cameras == "ground-truth";
  for (const std::string& dataset : o.datasets) {
    const LoadedDbarfScene loaded = LoadDbarfScene(dataset, o.scene);
    if (!loaded.ground_truth.defined())
      ThrowInputError(dataset, "", "a dataset with ground-truth poses (not the output of dbarf poses)");
    const RelativePoseError net =
        EvaluateRelativePoses(model, loaded.scene, loaded.ground_truth, o.num_sources, o.pose_init);
    // The start: the identity (rotation error = the true angle; direction undefined, 90 deg) or the cameras.
    const RelativePoseError start =
        o.pose_init == "cameras" ? EvaluateCameraRelativePoses(loaded.scene, loaded.ground_truth, o.num_sources)
                                 : EvaluateIdentityRelativePoses(loaded.scene, loaded.ground_truth, o.num_sources);
    rows.push_back({{"dataset", dataset},
                    {"pairs", net.pairs},
                    {"start_rotation_deg", start.rotation_deg},
                    {"rotation_deg", net.rotation_deg},
                    {"start_translation_direction_deg", start.translation_deg},
                    {"translation_direction_deg", net.translation_deg},
                    {"disparity", net.disparity}});
    if (same_units) rows.back()["translation_ratio"] = net.translation_ratio;
    if (on_row) on_row(rows.back());
    sum_rot += net.rotation_deg, sum_dir += net.translation_deg;
    sum_ratio += net.translation_ratio, sum_disparity += net.disparity;
    sum_start_rot += start.rotation_deg, sum_start_dir += start.translation_deg;
  }
  const double n = static_cast<double>(o.datasets.size());
  Json result = {{"weights", o.weights},
                 {"pose_init", o.pose_init},
                 {"sources", o.num_sources},
                 {"datasets", o.datasets.size()},
                 {"start_rotation_deg", sum_start_rot / n},
                 {"rotation_deg", sum_rot / n},
                 {"start_translation_direction_deg", sum_start_dir / n},
                 {"translation_direction_deg", sum_dir / n},
                 {"disparity", sum_disparity / n},
                 {"rows", rows}};
  if (same_units) result["translation_ratio"] = sum_ratio / n;
  return result;
}

}  // namespace nerfreg
