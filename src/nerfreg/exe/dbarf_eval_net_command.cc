// dbarf eval-net: the pose network's relative poses against ground truth (dbarf_data/
// evaluate_pose_network.h). In the learned-core build too, so a GPU machine scores what it trained.
#include <cstdio>

#include "nerfreg/dbarf_data/evaluate_pose_network.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/exe/scene_camera_flags.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

int RunDbarfEvalNet(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "The pose network's relative poses against ground truth, per dataset: each usable view as target, "
                  "its view-graph neighbours as sources, the network starting from the identity (--pose-init network, "
                  "the original) or from the estimated cameras; rotation error and translation-direction error (scale-"
                  "free) averaged over the pairs, next to the error of the start (identity: the true rotation angle).",
                  "nerfreg dbarf eval-net data/dbarf/val_*/transforms.json --weights runs/dbarf/net.pt");
  PoseNetworkEvaluationOptions o;
  o.weights = DefaultDbarfWeights();
  std::string json_out;
  app.add_option("datasets", o.datasets, "Datasets with ground-truth poses")->required();
  app.add_option("--weights", o.weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--pose-init", o.pose_init, "network (from the identity) or cameras")
      ->check(CLI::IsMember({"network", "cameras"}));
  app.add_option("--sources", o.num_sources, "Sources per target (view-graph neighbours, best first)");
  app.add_option("--json-out", json_out, "Also write the rows and means to this JSON file");
  app.add_option("--scene-cameras", o.scene.cameras, "Views chosen by: estimated cameras or ground-truth")
      ->check(CLI::IsMember({"estimated", "ground-truth"}));
  SceneCameraFlags cameras;
  cameras.AddOptions(app);
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  o.device = ParseDevice(device);
  o.scene.estimate_cameras = cameras.Estimator();
  if (!json_out.empty()) CheckCanWriteOutput(json_out, common.force, o.datasets);
  const char* row_format = "%-40s %7s %12.3f %12.3f %12.2f %12.2f\n";
  if (!common.json)
    std::printf("%-40s %7s %12s %12s %12s %12s\n", "dataset", "pairs", "start rot", "net rot", "start dir", "net dir");
  const Json result = EvaluatePoseNetwork(o, [&](const Json& row) {
    if (common.json) return;
    std::printf(row_format, row["dataset"].get<std::string>().c_str(), std::to_string(row["pairs"].get<int>()).c_str(),
                row["start_rotation_deg"].get<double>(), row["rotation_deg"].get<double>(),
                row["start_translation_direction_deg"].get<double>(), row["translation_direction_deg"].get<double>());
    std::fflush(stdout);
  });
  if (!json_out.empty()) WriteJsonFile(json_out, result);
  if (common.json) {
    std::printf("%s\n", result.dump().c_str());
  } else {
    std::printf(row_format, "mean", "", result["start_rotation_deg"].get<double>(),
                result["rotation_deg"].get<double>(), result["start_translation_direction_deg"].get<double>(),
                result["translation_direction_deg"].get<double>());
  }
  return 0;
}
