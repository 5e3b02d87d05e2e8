// dbarf eval: the whole pose-free pipeline against ground truth (dbarf eval-net, the pose network
// alone, is in dbarf_eval_net_command.cc, in the learned core too).
#include <cstdio>

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
