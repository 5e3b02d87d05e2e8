// Commands of DBARF's learned part: dbarf pretrain | finetune (training, resumable) | render (novel
// views from posed images); dbarf eval is in dbarf_eval_commands.cc, eval-net in
// dbarf_eval_net_command.cc. These are in the learned-core build too, which estimates no cameras
// from images (no SfM): there a dataset whose poses are ground truth needs --scene-cameras
// ground-truth, and --sfm-cache is absent.
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/dbarf_data/render_dbarf_views.h"
#include "nerfreg/dbarf_data/train_dbarf.h"
#include "nerfreg/dist/dist.h"
#include "nerfreg/dist/launch.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/exe/scene_camera_flags.h"
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

void AddTrainOptions(CLI::App& app, DbarfTrainingJob* c, SceneCameraFlags* estimation, std::string* device) {
  AddDeviceOption(app, device);
  app.add_option("--out", c->run.out, "Output weights (OUT.train: the state --resume continues; OUT.log.jsonl)")
      ->required();
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
  app.add_option(
      "--init-noise-translation", c->train.init_noise_translation,
      "Pose stages: perturb each camera initialisation's translation (per-axis std, fraction of its baseline)");
  app.add_flag(
      "--fresh-pose-heads", c->fresh_pose_heads,
      "Keep only the encoders of --weights and start the pose network's heads and update blocks afresh "
      "(the original starts from ImageNet encoders and fresh heads; with --pose-init network, self-supervised)");
  app.add_option("--lr-feature", c->train.lr_feature, "Feature-net learning rate");
  app.add_option("--lr-mlp", c->train.lr_mlp, "IBRNet learning rate");
  app.add_option("--lr-pose", c->train.lr_pose, "Pose-network learning rate");
  app.add_option("--joint-decay", c->train.joint_decay, "Joint stage: SfM weight a = 2^(-joint_decay * step)");
  app.add_option("--lr-decay-steps", c->train.lr_decay_steps, "Halve the learning rates every this many steps");
  app.add_option("--smoothness", c->train.sfm.smoothness_weight, "SfM loss: depth smoothness weight (original 0.01)");
  app.add_option("--auto-mask", c->train.sfm.auto_mask, "SfM loss: auto-masking, true or false (original true)");
  app.add_option("--sfm-clip", c->train.sfm.clip_std_factor,
                 "SfM loss: clip each error map at mean + this many standard deviations (original 0.5; < 0: no clip)");
  app.add_option("--sfm-levels", c->train.sfm.pyramid_levels,
                 "SfM loss: sum its photometric term over this many levels of an image pyramid (original 1)")
      ->check(CLI::Range(1, 6));
  app.add_option("--max-width", c->scene.max_width, "Downsample wider images to this width (0: as they are)");
  estimation->AddOptions(app);
  app.add_option("--scene-cameras", c->scene.cameras,
                 "Training cameras: estimated (from the images) or ground-truth (the datasets' own poses; views chosen "
                 "by true camera distance, as the original trains)")
      ->check(CLI::IsMember({"estimated", "ground-truth"}));
  app.add_option("--seed", c->train.seed, "Seed");
}

// Trains (with workers under --nproc) and prints the summary.
int RunTraining(DbarfTrainingJob& c, const CommonOptions& common, const DistOptions& dist, int argc, char** argv) {
  c.force = common.force;
  // Under --nproc on GPUs local worker r trains on cuda:r (NCCL); too few GPUs is refused here,
  // before any worker starts.
  c.run.device = ProcessDevice(c.run.device, dist);
  if (ShouldLaunch(dist) && !c.run.resume) {
    // Refused before any worker starts (each would refuse alike).
    std::vector<std::string> inputs = c.scenes;
    inputs.push_back(c.weights);
    CheckCanWriteOutput(c.run.out, c.force, inputs);
  }
  if (int rc = LaunchIfAsked(dist, argc, argv); rc >= 0) return rc;
  const auto group = DistGroup::FromEnvironment(dist.timeout_s, c.run.device);
  c.group = group.get();
  const DbarfTrainingResult r = TrainDbarf(c);
  if (common.json && group->is_main()) std::printf("%s\n", r.summary.dump().c_str());
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
  app.add_option("--augment-blur", c.train.blur_probability,
                 "Probability per step that the pose network sees the target blurred (radius 1-4 px; default 0)");
  app.add_option("--supervise-rotation-weight", c.train.supervise_rotation_weight,
                 "Weight of the rotation term of the supervised pose loss against the translation term (default 5)");
  app.add_option("--rotation-scale", c.rotation_scale,
                 "Scale on the rotation half of the pose heads' twists (default: the config's or the weights', 0.01 "
                 "as in the original; --weights keep their function, rescaled; a resumed run must give the same)");
  app.add_option("--batch", c.train.samples_per_step,
                 "Targets per step, their gradients averaged (default: one per process)");
  DistOptions dist;
  AddDistOptions(app, &dist);
  std::string device = "cpu";
  SceneCameraFlags estimation;
  AddTrainOptions(app, &c, &estimation, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  c.run.device = ParseDevice(device);
  c.scene.estimate_cameras = estimation.Estimator();
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
  return RunTraining(c, common, dist, argc, argv);
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
  app.add_option(
      "--refine-cameras", c.cameras_out,
      "Also refine the scene's cameras (one SE(3) correction per image, by the RGB loss of the NeRF stages, then "
      "a photometric bundle adjustment through the finetuned renderer's depths, --depth-ba-*; needs --nerf-poses "
      "cameras and a scene written by dbarf poses) and write them to this transforms.json");
  app.add_option("--lr-cameras", c.train.lr_cameras,
                 "Camera-refinement learning rate (3e-4: for the sub-degree cameras of dbarf poses; 3e-3 corrects "
                 "cameras degrees off faster)");
  app.add_option("--depth-ba-rounds", c.depth_refinement.rounds,
                 "With --refine-cameras, after the training: rounds of a photometric bundle adjustment of the "
                 "cameras through the finetuned renderer's depths (0: the RGB loss's cameras as they are)");
  app.add_option("--depth-ba-sources", c.depth_refinement.num_sources,
                 "Nearest views each view is warped from (and rendered from) in that bundle adjustment");
  app.add_option("--depth-ba-steps", c.depth_refinement.ba.iterations_per_level,
                 "Steps per pyramid level of that bundle adjustment");
  app.add_option("--depth-ba-max-width", c.depth_refinement.max_width,
                 "Render and warp at most this wide in that bundle adjustment (0: the scene's size)");
  app.add_option("--depth-ba-view-range", c.depth_refinement.view_range_margin,
                 "Render each view's depths again over the range its first render spans, widened by this factor "
                 "(> 1; 0: once, over the scene's depth range)");
  std::string device = "cpu";
  SceneCameraFlags estimation;
  AddTrainOptions(app, &c, &estimation, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  c.run.device = ParseDevice(device);
  c.scene.estimate_cameras = estimation.Estimator();
  c.depth_refinement.Check();
  c.scenes = {scene};
  c.train.refine_cameras = !c.cameras_out.empty();
  if (c.train.refine_cameras) CheckCanWriteOutput(c.cameras_out, common.force, {scene, c.weights});
  // The configuration is the starting weights' (or, resuming, the run's own).
  const DbarfModel start = LoadDbarfWeights(c.run.resume ? c.run.out : c.weights);
  c.config = DbarfOptionsToJson(start.options) == DbarfOptionsToJson(DbarfOptions::Paper()) ? "paper" : "cpu";
  c.kind = "finetune";
  return RunTraining(c, common, DistOptions(), argc, argv);
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
  app.add_option("posed", job.posed, "Posed images: transforms.json written by dbarf poses (or any posed dataset)")
      ->required();
  app.add_option("--transforms", job.transforms, "Cameras to render (transforms.json, LLFF or COLMAP)")->required();
  app.add_option("--out", job.out, "Output folder")->required();
  app.add_option("--weights", job.weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--sources", job.num_sources, "Source views per rendered view (nearest cameras)");
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  job.device = ParseDevice(device);
  job.force = common.force;
  job.estimate_cameras = SceneCameraFlags().Estimator();
  RenderDbarfViews(job);
  return 0;
}
