// Commands that score DBARF against ground truth: dbarf eval (the whole pose-free pipeline) and
// dbarf eval-net (the pose network's relative poses).
#include <cmath>
#include <cstdio>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/dbarf_sfm/scene_cameras.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/pipeline/evaluate_dbarf.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

int RunDbarfEval(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "The pose-free pipeline against ground truth: every image of the dataset (train and test split) is "
                  "posed from the images alone; poses are scored after a Sim(3) alignment; each test view is rendered "
                  "at its ESTIMATED camera from its view-graph neighbours among the training views, and scored by "
                  "PSNR / SSIM against its image, and, where the dataset has depth maps (render --depth), by its "
                  "rendered depth's median relative error, scale-aligned. Writes DIR/eval.json, DIR/views/ (renders, "
                  "inverse depth) and DIR/compare.png (image | render | depth per test view).",
                  "nerfreg dbarf eval data/fwd/scene_201/transforms.json --out runs/eval_201");
  DbarfEvaluationOptions o;
  o.weights = DefaultDbarfWeights();
  app.add_option("dataset", o.dataset, "A dataset with ground-truth poses and a test split")->required();
  app.add_option("--weights", o.weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--out", o.out, "Output folder")->required();
  app.add_option("--cameras", o.cameras,
                 "Evaluate these cameras (a transforms.json of dbarf poses --method M, or of dbarf finetune "
                 "--refine-cameras) instead of estimating them");
  app.add_option("--sources", o.num_sources, "Source views per rendered view");
  app.add_option("--max-width", o.scene.max_width, "Downsample wider images to this width (0: as they are)");
  app.add_option("--perturb-deg", o.perturb.deg,
                 "Also score the network refining cameras perturbed by this rotation (deg, per-axis std)");
  app.add_option("--perturb-translation", o.perturb.translation,
                 "... and this translation (per-axis std, fraction of each baseline)");
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  o.device = ParseDevice(device);
  o.force = common.force;
  const DbarfEvaluation e = EvaluateDbarf(o);
  if (common.json) {
    std::printf("%s\n", e.json.dump().c_str());
    return 0;
  }
  const PoseEvaluation& pe = e.poses;
  std::printf("posed              %zu / %lld\n", e.posed, static_cast<long long>(e.images));
  std::printf("rotation (deg)     median %.4f  mean %.4f\n", pe.median_rotation_deg, pe.mean_rotation_deg);
  std::printf("centre             median %.5f  (%.3f %% of the widest baseline)\n", pe.median_center,
              pe.median_center_percent);
  std::printf("relative poses     cameras %.4f deg / direction %.3f deg; network %.4f / %.3f deg (%d pairs)\n",
              e.relative_cameras.rotation_deg, e.relative_cameras.translation_deg, e.relative_network.rotation_deg,
              e.relative_network.translation_deg, e.relative_network.pairs);
  std::printf("novel views        %zu rendered: PSNR %.2f dB  SSIM %.4f\n", e.rendered, e.psnr_mean, e.ssim_mean);
  if (e.depth_error_median >= 0) {
    std::printf("rendered depth     median relative error %.2f %% (against the dataset's depth maps, scale-aligned)\n",
                100 * e.depth_error_median);
  }
  std::printf("time               %.1f s (poses %.1f s)\n", e.seconds, e.seconds_poses);
  return 0;
}

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
  std::vector<std::string> datasets;
  std::string weights = DefaultDbarfWeights(), pose_init = "network", json_out;
  int num_sources = 5;
  DbarfSceneOptions scene_options;
  app.add_option("datasets", datasets, "Datasets with ground-truth poses")->required();
  app.add_option("--weights", weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--pose-init", pose_init, "network (from the identity) or cameras")
      ->check(CLI::IsMember({"network", "cameras"}));
  app.add_option("--sources", num_sources, "Sources per target (view-graph neighbours, best first)");
  app.add_option("--json-out", json_out, "Also write the rows and means to this JSON file");
  app.add_option("--scene-cameras", scene_options.cameras, "Views chosen by: estimated cameras or ground-truth")
      ->check(CLI::IsMember({"estimated", "ground-truth"}));
  SfmSceneCamerasOptions sfm_cameras;
  app.add_option("--sfm-cache", sfm_cameras.cache_dir, "Reuse the cameras estimated from each scene's images");
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const torch::Device dev = ParseDevice(device);
  if (num_sources < 1) throw InputError("--sources: expected >= 1, got " + std::to_string(num_sources));
  scene_options.estimate_cameras = SfmCameraEstimator(sfm_cameras);
  DbarfModel model = LoadDbarfWeights(weights);
  model.To(dev);
  Json rows = Json::array();
  double sum_rot = 0, sum_dir = 0, sum_start_rot = 0, sum_start_dir = 0;
  int n = 0;
  if (!common.json)
    std::printf("%-40s %7s %12s %12s %12s %12s\n", "dataset", "pairs", "start rot", "net rot", "start dir", "net dir");
  for (const std::string& dataset : datasets) {
    const LoadedDbarfScene loaded = LoadDbarfScene(dataset, scene_options);
    if (!loaded.ground_truth.defined())
      ThrowInputError(dataset, "", "a dataset with ground-truth poses (not the output of dbarf poses)");
    const RelativePoseError net =
        EvaluateRelativePoses(model, loaded.scene, loaded.ground_truth, num_sources, pose_init);
    // The start: the identity (rotation error = the true angle; direction undefined, 90 deg) or the cameras.
    const RelativePoseError start = pose_init == "cameras"
                                        ? EvaluateCameraRelativePoses(loaded.scene, loaded.ground_truth, num_sources)
                                        : EvaluateIdentityRelativePoses(loaded.scene, loaded.ground_truth, num_sources);
    rows.push_back({{"dataset", dataset},
                    {"pairs", net.pairs},
                    {"start_rotation_deg", start.rotation_deg},
                    {"rotation_deg", net.rotation_deg},
                    {"start_translation_direction_deg", start.translation_deg},
                    {"translation_direction_deg", net.translation_deg}});
    if (!common.json) {
      std::printf("%-40s %7d %12.3f %12.3f %12.2f %12.2f\n", dataset.c_str(), net.pairs, start.rotation_deg,
                  net.rotation_deg, start.translation_deg, net.translation_deg);
      std::fflush(stdout);
    }
    sum_rot += net.rotation_deg, sum_dir += net.translation_deg;
    sum_start_rot += start.rotation_deg, sum_start_dir += start.translation_deg;
    ++n;
  }
  const Json result = {{"weights", weights},
                       {"pose_init", pose_init},
                       {"sources", num_sources},
                       {"datasets", n},
                       {"start_rotation_deg", sum_start_rot / n},
                       {"rotation_deg", sum_rot / n},
                       {"start_translation_direction_deg", sum_start_dir / n},
                       {"translation_direction_deg", sum_dir / n},
                       {"rows", rows}};
  if (!json_out.empty()) WriteJsonFile(json_out, result);
  if (common.json) {
    std::printf("%s\n", result.dump().c_str());
  } else {
    std::printf("%-40s %7s %12.3f %12.3f %12.2f %12.2f\n", "mean", "", sum_start_rot / n, sum_rot / n,
                sum_start_dir / n, sum_dir / n);
  }
  return 0;
}
