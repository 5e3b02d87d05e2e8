// Commands of DBARF's learned part: dbarf pretrain | finetune (training, resumable) | render (novel
// views from posed images) | eval (the whole pose-free pipeline against ground truth).
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/pipeline/evaluate_dbarf.h"
#include "nerfreg/pipeline/render_dbarf_views.h"
#include "nerfreg/pipeline/train_dbarf.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

std::string DefaultDbarfWeights() {
  if (const char* env = std::getenv("NERFREG_DBARF_WEIGHTS")) return env;
  return std::string(NERFREG_MODELS_DIR) + "/dbarf_cpu.pt";
}

std::string DefaultDbarfPoseWeights() {
  if (const char* env = std::getenv("NERFREG_DBARF_POSE_WEIGHTS")) return env;
  return std::string(NERFREG_MODELS_DIR) + "/dbarf_pose_cpu.pt";
}

namespace {

void AddTrainOptions(CLI::App& app, DbarfTrainingJob* c, std::string* device) {
  AddDeviceOption(app, device);
  app.add_option("--out", c->run.out, "Output weights (OUT.train: the state --resume continues; OUT.log.jsonl)")->required();
  app.add_option("--steps", c->run.steps, "Total steps (a resumed run counts its earlier steps)");
  app.add_option("--checkpoint-every", c->run.checkpoint_every, "Steps between checkpoints (default 250)");
  app.add_flag("--resume", c->run.resume, "Continue from OUT and OUT.train");
  app.add_option("--schedule", c->train.schedule, "dbarf (pose / nerf / joint stages) or nerf (renderer only)")
      ->check(CLI::IsMember({"dbarf", "nerf"}));
  app.add_option("--stage-steps", c->train.stage_steps, "Steps per stage block (original 10000)");
  app.add_option("--sources", c->train.num_sources, "Source views per step before the jitter");
  app.add_option("--rays", c->train.rays_per_step, "Rays per step at 5 sources (scaled by 5 / N)");
  app.add_option("--pose-init", c->train.pose_init, "network (the original) or cameras (refine the estimated cameras)")
      ->check(CLI::IsMember({"network", "cameras"}));
  app.add_option("--nerf-poses", c->train.nerf_poses, "Sources of the NeRF-only stage placed by: network or cameras")
      ->check(CLI::IsMember({"network", "cameras"}));
  app.add_option("--init-noise-deg", c->train.init_noise_deg,
                 "Pose stages: perturb each camera initialisation by this rotation (deg, per-axis std) so the network "
                 "learns to correct errors");
  app.add_option("--init-noise-translation", c->train.init_noise_translation,
                 "Pose stages: perturb each camera initialisation's translation (per-axis std, fraction of its baseline)");
  app.add_option("--lr-feature", c->train.lr_feature, "Feature-net learning rate");
  app.add_option("--lr-mlp", c->train.lr_mlp, "IBRNet learning rate");
  app.add_option("--lr-pose", c->train.lr_pose, "Pose-network learning rate");
  app.add_option("--joint-decay", c->train.joint_decay, "Joint stage: SfM weight a = 2^(-joint_decay * step)");
  app.add_option("--lr-decay-steps", c->train.lr_decay_steps, "Halve the learning rates every this many steps");
  app.add_option("--smoothness", c->train.sfm.smoothness_weight, "SfM loss: depth smoothness weight (original 0.01)");
  app.add_option("--auto-mask", c->train.sfm.auto_mask, "SfM loss: auto-masking, true or false (original true)");
  app.add_option("--max-width", c->scene.max_width, "Downsample wider images to this width (0: as they are)");
  app.add_option("--sfm-cache", c->scene.sfm_cache_dir,
                 "Keep the cameras estimated from each scene's images in this folder and reuse them (clear it after "
                 "changing the SfM)");
  app.add_option("--scene-cameras", c->scene.cameras,
                 "Training cameras: estimated (from the images) or ground-truth (the datasets' own poses; views chosen "
                 "by true camera distance, as the original trains)")
      ->check(CLI::IsMember({"estimated", "ground-truth"}));
  app.add_option("--seed", c->train.seed, "Seed");
}

// Trains and prints the summary.
int RunTraining(DbarfTrainingJob& c, const CommonOptions& common) {
  c.force = common.force;
  const DbarfTrainingResult r = TrainDbarf(c);
  if (common.json) std::printf("%s\n", r.summary.dump().c_str());
  return 0;
}

}  // namespace

int RunDbarfPretrain(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Pretrain DBARF (generalizable NeRF + pose network) on many scenes. Each scene is a dataset in any "
                  "format (transforms.json, LLFF, COLMAP) or the output of dbarf poses; poses in datasets are never "
                  "used: cameras, depth range and view graph are estimated from the images.",
                  "nerfreg dbarf pretrain data/fwd/scene_*/transforms.json --steps 4000 --out models/dbarf_cpu.pt");
  DbarfTrainingJob c;
  c.train = DbarfTrainOptions::Pretrain();
  c.train.pose_init = "cameras";
  app.add_option("scenes", c.scenes, "Scene datasets")->required();
  app.add_option("--config", c.config, "Network sizes: cpu or paper")->check(CLI::IsMember({"cpu", "paper"}));
  app.add_option("--weights", c.weights, "Weights to continue pretraining from (default: a fresh network)");
  app.add_option("--supervise-poses", c.train.supervise_poses,
                 "Weight of a SUPERVISED loss on the pose network's relative poses against the datasets' own poses "
                 "(rescaled to the estimated cameras; a departure from the self-supervised original; 0: off)");
  app.add_option("--supervise-depth", c.train.supervise_depth,
                 "Weight of an SfM loss on the predicted depth with the sources placed by the datasets' own relative "
                 "poses (a departure like --supervise-poses; 0: off)");
  app.add_option("--supervise-rotation-weight", c.train.supervise_rotation_weight,
                 "Weight of the rotation term of the supervised pose loss against the translation term (default 5)");
  app.add_option("--rotation-scale", c.rotation_scale,
                 "Scale on the rotation half of the pose heads' twists (default: the config's or the weights', 0.01 "
                 "as in the original; --weights keep their function, rescaled; a resumed run must give the same)");
  std::string device = "cpu";
  AddTrainOptions(app, &c, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  c.run.device = ParseDevice(device);
  if (c.rotation_scale < 0 || !std::isfinite(c.rotation_scale)) {
    throw InputError("--rotation-scale: expected > 0, got " + std::to_string(c.rotation_scale));
  }
  if (!c.weights.empty() && !c.run.resume) {
    // The configuration is the starting weights'. Their rotation scale is a scale of the pose
    // heads' output, not of the architecture (--rotation-scale rescales it, keeping the function).
    DbarfOptions expected = DbarfOptions::Named(c.config);
    expected.pose.rotation_scale = LoadDbarfWeights(c.weights).options.pose.rotation_scale;
    LoadDbarfWeights(c.weights, &expected);
  }
  return RunTraining(c, common);
}

int RunDbarfFinetune(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Finetune DBARF weights on one scene (10 sources, lower rates: the original's finetuning). The "
                  "scene is the output of dbarf poses or any dataset (its poses are not used).",
                  "nerfreg dbarf finetune runs/poses/transforms.json --steps 1000 --out runs/scene.dbarf.pt");
  DbarfTrainingJob c;
  c.train = DbarfTrainOptions::Finetune();
  c.train.pose_init = "cameras";
  std::string scene;
  c.weights = DefaultDbarfWeights();
  app.add_option("scene", scene, "The scene")->required();
  app.add_option("--weights", c.weights, "Weights to start from (default: the shipped ones)");
  app.add_option("--refine-cameras", c.cameras_out,
                 "Also refine the scene's cameras (one SE(3) correction per image, by the RGB loss of the NeRF stages; "
                 "needs --nerf-poses cameras and a scene written by dbarf poses) and write them to this transforms.json");
  app.add_option("--lr-cameras", c.train.lr_cameras, "Camera-refinement learning rate");
  std::string device = "cpu";
  AddTrainOptions(app, &c, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  c.run.device = ParseDevice(device);
  c.scenes = {scene};
  c.train.refine_cameras = !c.cameras_out.empty();
  if (c.train.refine_cameras) CheckCanWriteOutput(c.cameras_out, common.force, {scene, c.weights});
  // The configuration is the starting weights' (or, resuming, the run's own).
  const DbarfModel start = LoadDbarfWeights(c.run.resume ? c.run.out : c.weights);
  c.config = DbarfOptionsToJson(start.options) == DbarfOptionsToJson(DbarfOptions::Paper()) ? "paper" : "cpu";
  c.kind = "finetune";
  return RunTraining(c, common);
}

int RunDbarfRender(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Render novel views with the generalizable NeRF from posed images (the output of dbarf poses): one "
                  "PNG per frame of T.json (cameras in the posed images' frame), named as the frame, and its inverse "
                  "depth in DIR/depth/.",
                  "nerfreg dbarf render runs/poses/transforms.json --transforms novel.json --out runs/novel");
  DbarfRenderJob job;
  job.weights = DefaultDbarfWeights();
  app.add_option("posed", job.posed, "Posed images: transforms.json written by dbarf poses (or any posed dataset)")->required();
  app.add_option("--transforms", job.transforms, "Cameras to render (transforms.json, LLFF or COLMAP)")->required();
  app.add_option("--out", job.out, "Output folder")->required();
  app.add_option("--weights", job.weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--sources", job.num_sources, "Source views per rendered view (nearest cameras)");
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  job.device = ParseDevice(device);
  job.force = common.force;
  RenderDbarfViews(job);
  return 0;
}

int RunDbarfEval(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "The pose-free pipeline against ground truth: every image of the dataset (train and test split) is "
                  "posed from the images alone; poses are scored after a Sim(3) alignment; each test view is rendered "
                  "at its ESTIMATED camera from its view-graph neighbours among the training views, and scored by "
                  "PSNR / SSIM against its image. Writes DIR/eval.json, DIR/views/ (renders, inverse depth) and "
                  "DIR/compare.png (image | render | depth per test view).",
                  "nerfreg dbarf eval data/fwd/scene_201/transforms.json --out runs/eval_201");
  DbarfEvaluationOptions o;
  o.weights = DefaultDbarfWeights();
  app.add_option("dataset", o.dataset, "A dataset with ground-truth poses and a test split")->required();
  app.add_option("--weights", o.weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--out", o.out, "Output folder")->required();
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
  app.add_option("--pose-init", pose_init, "network (from the identity) or cameras")->check(CLI::IsMember({"network", "cameras"}));
  app.add_option("--sources", num_sources, "Sources per target (view-graph neighbours, best first)");
  app.add_option("--json-out", json_out, "Also write the rows and means to this JSON file");
  app.add_option("--scene-cameras", scene_options.cameras, "Views chosen by: estimated cameras or ground-truth")
      ->check(CLI::IsMember({"estimated", "ground-truth"}));
  app.add_option("--sfm-cache", scene_options.sfm_cache_dir, "Reuse the cameras estimated from each scene's images");
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const torch::Device dev = ParseDevice(device);
  if (num_sources < 1) throw InputError("--sources: expected >= 1, got " + std::to_string(num_sources));
  DbarfModel model = LoadDbarfWeights(weights);
  model.To(dev);
  Json rows = Json::array();
  double sum_rot = 0, sum_dir = 0, sum_start_rot = 0, sum_start_dir = 0;
  int n = 0;
  if (!common.json) std::printf("%-40s %7s %12s %12s %12s %12s\n", "dataset", "pairs", "start rot", "net rot", "start dir", "net dir");
  for (const std::string& dataset : datasets) {
    const LoadedDbarfScene loaded = LoadDbarfScene(dataset, scene_options);
    if (!loaded.ground_truth.defined()) ThrowInputError(dataset, "", "a dataset with ground-truth poses (not the output of dbarf poses)");
    const RelativePoseError net = EvaluateRelativePoses(model, loaded.scene, loaded.ground_truth, num_sources, pose_init);
    // The start: the identity (rotation error = the true angle; direction undefined, 90 deg) or the cameras.
    const RelativePoseError start = pose_init == "cameras"
                                        ? EvaluateCameraRelativePoses(loaded.scene, loaded.ground_truth, num_sources)
                                        : EvaluateIdentityRelativePoses(loaded.scene, loaded.ground_truth, num_sources);
    rows.push_back({{"dataset", dataset}, {"pairs", net.pairs}, {"start_rotation_deg", start.rotation_deg},
                    {"rotation_deg", net.rotation_deg}, {"start_translation_direction_deg", start.translation_deg},
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
