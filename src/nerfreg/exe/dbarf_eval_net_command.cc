// dbarf eval-net: the pose network's relative poses against ground truth (dbarf_data/
// evaluate_pose_network.h). In the learned-core build too, so a GPU machine scores what it trained.
#include <cstdio>
#include <string>

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
  // |t| / |t_true| only with ground-truth scene cameras (the truth in the depth range's units).
  const auto print_row = [](const std::string& name, const std::string& pairs, const Json& r) {
    char ratio[32] = "-";
    if (r.contains("translation_ratio"))
      std::snprintf(ratio, sizeof(ratio), "%.3f", r["translation_ratio"].get<double>());
    std::printf("%-40s %7s %12.3f %12.3f %12.2f %12.2f %10.3f %10s\n", name.c_str(), pairs.c_str(),
                r["start_rotation_deg"].get<double>(), r["rotation_deg"].get<double>(),
                r["start_translation_direction_deg"].get<double>(), r["translation_direction_deg"].get<double>(),
                r["disparity"].get<double>(), ratio);
    std::fflush(stdout);
  };
  if (!common.json)
    std::printf("%-40s %7s %12s %12s %12s %12s %10s %10s\n", "dataset", "pairs", "start rot", "net rot", "start dir",
                "net dir", "disparity", "|t|/|t*|");
  const Json result = EvaluatePoseNetwork(o, [&](const Json& row) {
    if (!common.json) print_row(row["dataset"].get<std::string>(), std::to_string(row["pairs"].get<int>()), row);
  });
  if (!json_out.empty()) WriteJsonFile(json_out, result);
  if (common.json) {
    std::printf("%s\n", result.dump().c_str());
  } else {
    print_row("mean", "", result);
  }
  return 0;
}
