// Commands of DBARF's learned part: dbarf pretrain | finetune (training, resumable) | render (novel
// views from posed images) | eval (the whole pose-free pipeline against ground truth).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>

#include "nerfreg/data/convert.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/dbarf_scene.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/util/torch_device.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/image_metrics.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"

using namespace nerfreg;
namespace fs = std::filesystem;

std::string DefaultDbarfWeights() {
  if (const char* env = std::getenv("NERFREG_DBARF_WEIGHTS")) return env;
  return std::string(NERFREG_MODELS_DIR) + "/dbarf_cpu.pt";
}

std::string DefaultDbarfPoseWeights() {
  if (const char* env = std::getenv("NERFREG_DBARF_POSE_WEIGHTS")) return env;
  return std::string(NERFREG_MODELS_DIR) + "/dbarf_pose_cpu.pt";
}

namespace {

struct TrainCli {
  std::vector<std::string> scenes;
  std::string out, config = "cpu", weights;
  std::string cameras_out;  // finetune --refine-cameras: where the refined cameras go
  double rotation_scale = 0;  // pretrain: the pose heads' rotation scale (0: the config's or the weights')
  std::string device = "cpu";
  DbarfTrainOptions train;
  DbarfRunOptions run;
  DbarfSceneOptions scene;
};

void AddTrainOptions(CLI::App& app, TrainCli* c) {
  AddDeviceOption(app, &c->device);
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
  app.add_option("--seed", c->train.seed, "Seed");
}

std::vector<LoadedDbarfScene> LoadScenes(const std::vector<std::string>& paths, const DbarfSceneOptions& options) {
  std::vector<LoadedDbarfScene> scenes;
  ProgressBar bar("loading scenes", static_cast<int64_t>(paths.size()), "scene");
  for (const auto& p : paths) {
    scenes.push_back(LoadDbarfScene(p, options));
    for (const auto& name : scenes.back().not_posed) LOG_WARN("{}: {} could not be posed; left out", p, name);
    bar.Tick();
  }
  bar.Finish();
  return scenes;
}

// The input posed-images file (written by dbarf poses) with every frame's camera replaced by the
// refined one; image paths relative to the output's folder; view graph and depth range kept.
void WriteRefinedCameras(const std::string& input, const LoadedDbarfScene& loaded, const torch::Tensor& cam_from_world,
                         const std::string& path) {
  const Json original = ReadJsonFile(TransformsJsonPath(input));
  Dataset d = loaded.dataset;
  const fs::path out_dir = fs::absolute(fs::path(path)).parent_path();
  for (size_t k = 0; k < d.frames.size(); ++k) {
    Frame& f = d.frames[k];
    f.file_path = fs::relative(fs::absolute(d.ImagePath(f)), out_dir).generic_string();
    f.cam_from_world = Rigid3d::FromMatrix(TensorToMatrix4(cam_from_world[static_cast<int64_t>(k)]), 1e-3);
  }
  d.root = out_dir.string();
  Json json = TransformsJsonFromDataset(d);
  for (const char* key : {"view_graph", "not_posed", "dbarf_poses"})
    if (original.contains(key)) json[key] = original[key];
  json["dbarf_poses"]["refined"] = "dbarf finetune --refine-cameras (RGB loss of the NeRF stages)";
  WriteJsonFile(path, json);
}

int RunTraining(TrainCli& c, const CommonOptions& common, const char* what) {
  c.run.device = ParseDevice(c.device);
  std::vector<std::string> inputs = c.scenes;
  inputs.push_back(c.weights);
  if (!c.run.resume) CheckCanWriteOutput(c.run.out, common.force, inputs);
  c.train.Check();
  c.run.Check();
  // Weights and state first: a wrong file fails before minutes of scene loading.
  if (c.run.resume && !FileExists(c.run.out + ".train")) {
    ThrowInputError(c.run.out + ".train", "", "a training state to resume (written by dbarf pretrain / finetune)");
  }
  DbarfOptions expected = DbarfOptions::Named(c.config);
  if (c.rotation_scale > 0) expected.pose.rotation_scale = c.rotation_scale;
  DbarfModel model = c.run.resume ? LoadDbarfWeights(c.run.out, &expected)
                                  : (c.weights.empty() ? DbarfModel(expected) : LoadDbarfWeights(c.weights));
  if (!c.run.resume && !c.weights.empty() && c.rotation_scale > 0) {
    model.pose_net->SetRotationScale(c.rotation_scale);
    model.options.pose.rotation_scale = c.rotation_scale;
  }
  const std::vector<LoadedDbarfScene> loaded = LoadScenes(c.scenes, c.scene);
  if (!c.cameras_out.empty() && loaded[0].estimated_here) {
    ThrowInputError(c.scenes[0], "dbarf_poses", "posed images written by dbarf poses (--refine-cameras refines their cameras)");
  }
  std::vector<DbarfScene> scenes;
  for (size_t i = 0; i < loaded.size(); ++i) {
    scenes.push_back(loaded[i].scene);
    // The dataset's own poses, kept apart from the estimated cameras: read only by the supervised
    // pose loss and the log's error columns.
    if ((c.train.supervise_poses > 0 || c.train.supervise_depth > 0) && !loaded[i].ground_truth.defined()) {
      ThrowInputError(c.scenes[i], "poses", "a dataset with ground-truth poses (--supervise-poses), not dbarf poses output");
    }
    if (loaded[i].ground_truth.defined()) {
      scenes.back().supervision_cam_from_world = GroundTruthInEstimatedScale(
          loaded[i].ground_truth, loaded[i].scene.cam_from_world, loaded[i].scene.usable, c.scenes[i]);
    }
  }
  if (!c.run.resume) {
    model.training = Json::object();
    model.training["kind"] = what;
    model.training["pose_init"] = c.train.pose_init;
    model.training["supervise_poses"] = c.train.supervise_poses;
    model.training["supervise_depth"] = c.train.supervise_depth;
    if (!c.weights.empty()) model.training["initial_weights"] = c.weights;
  }
  model.training["data"] = c.scenes;
  const DbarfRunResult r = RunDbarfTraining(&model, scenes, c.train, c.run);
  const Json summary = {{"steps", r.steps}, {"seconds", r.seconds}, {"psnr_train_last", r.mean_psnr_last},
                        {"sfm_loss_last", r.mean_sfm_last}, {"weights", c.run.out}, {"scenes", c.scenes.size()}};
  WriteJsonFile(c.run.out + ".json", summary);
  if (!c.cameras_out.empty()) {
    WriteRefinedCameras(c.scenes[0], loaded[0], r.cameras[0], c.cameras_out);
    LOG_INFO("refined cameras -> {}", c.cameras_out);
  }
  if (common.json) std::printf("%s\n", summary.dump().c_str());
  LOG_INFO("{}: {} steps in {:.1f} s, training PSNR (last 10%) {:.2f} dB -> {}", what, r.steps, r.seconds,
           r.mean_psnr_last, c.run.out);
  return 0;
}

Image DepthImage(const torch::Tensor& depth, const torch::Tensor& valid, double near, double far) {
  // Inverse depth for viewing: near is white, far black, invalid pixels black.
  const torch::Tensor inv = ((1.0 / depth.clamp_min(1e-6) - 1.0 / far) / (1.0 / near - 1.0 / far)).clamp(0, 1) *
                            valid.to(torch::kFloat);
  return TensorToImage(inv.unsqueeze(0));
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
  TrainCli c;
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
  AddTrainOptions(app, &c);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (c.rotation_scale < 0 || !std::isfinite(c.rotation_scale)) {
    throw InputError("--rotation-scale: expected > 0, got " + std::to_string(c.rotation_scale));
  }
  if (!c.weights.empty() && !c.run.resume) {
    // The configuration is the starting weights'.
    const DbarfOptions expected = DbarfOptions::Named(c.config);
    LoadDbarfWeights(c.weights, &expected);
  }
  return RunTraining(c, common, "pretrain");
}

int RunDbarfFinetune(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Finetune DBARF weights on one scene (10 sources, lower rates: the original's finetuning). The "
                  "scene is the output of dbarf poses or any dataset (its poses are not used).",
                  "nerfreg dbarf finetune runs/poses/transforms.json --steps 1000 --out runs/scene.dbarf.pt");
  TrainCli c;
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
  AddTrainOptions(app, &c);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  c.run.device = ParseDevice(c.device);  // before the weights are read (RunTraining parses it too)
  c.scenes = {scene};
  c.train.refine_cameras = !c.cameras_out.empty();
  if (c.train.refine_cameras) CheckCanWriteOutput(c.cameras_out, common.force, {scene, c.weights});
  // The configuration is the starting weights' (or, resuming, the run's own).
  const DbarfModel start = LoadDbarfWeights(c.run.resume ? c.run.out : c.weights);
  c.config = DbarfOptionsToJson(start.options) == DbarfOptionsToJson(DbarfOptions::Paper()) ? "paper" : "cpu";
  return RunTraining(c, common, "finetune");
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
  std::string posed, transforms, out, weights = DefaultDbarfWeights(), device = "cpu";
  AddDeviceOption(app, &device);
  int num_sources = 8;
  DbarfSceneOptions scene_options;
  scene_options.hold_out_test = false;
  app.add_option("posed", posed, "Posed images: transforms.json written by dbarf poses (or any posed dataset)")->required();
  app.add_option("--transforms", transforms, "Cameras to render (transforms.json, LLFF or COLMAP)")->required();
  app.add_option("--out", out, "Output folder")->required();
  app.add_option("--weights", weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--sources", num_sources, "Source views per rendered view (nearest cameras)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (num_sources < 1) throw InputError("--sources: expected >= 1");
  const torch::Device dev = ParseDevice(device);
  CheckCanWriteOutput(out, common.force, {posed, transforms, weights});
  DbarfModel model = LoadDbarfWeights(weights);
  model.To(dev);
  LoadedDbarfScene loaded = LoadDbarfScene(posed, scene_options);
  if (loaded.estimated_here) {
    LOG_WARN("{}: not written by dbarf poses; its cameras were estimated again, so the frame is that of this run, "
             "not the file's", posed);
  }
  const Dataset cams = ReadCameras(transforms);
  OutputDir output(out, common.force, {posed, transforms, weights});
  const std::string& tmp = output.tmp();
  CreateDirectories(JoinPaths(tmp, "depth"));
  {
    ProgressBar bar("dbarf render", static_cast<int64_t>(cams.frames.size()), "view");
    for (const Frame& f : cams.frames) {
      const torch::Tensor k = IntrinsicsToTensor(f.camera);
      const torch::Tensor pose = Matrix4ToTensor(f.cam_from_world.ToMatrix());
      const std::vector<int> sources = NearestViews(loaded.scene, pose, num_sources);
      const NovelView v = RenderNovelView(model, loaded.scene, sources, k, pose, f.camera.height, f.camera.width);
      std::string name = fs::path(f.name).replace_extension(".png").string();
      WriteImage(JoinPaths(tmp, name), TensorToImage(v.rgb));
      WriteImage(JoinPaths(tmp, "depth/" + name), DepthImage(v.depth, v.valid, loaded.scene.near, loaded.scene.far));
      bar.Tick();
    }
    bar.Finish();
    output.Commit();
  }
  LOG_INFO("rendered {} views -> {}", cams.frames.size(), out);
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
  std::string dataset, out, weights = DefaultDbarfWeights(), device = "cpu";
  AddDeviceOption(app, &device);
  int num_sources = 8;
  DbarfSceneOptions scene_options;
  app.add_option("dataset", dataset, "A dataset with ground-truth poses and a test split")->required();
  app.add_option("--weights", weights, "DBARF weights (default: the shipped ones)");
  app.add_option("--out", out, "Output folder")->required();
  app.add_option("--sources", num_sources, "Source views per rendered view");
  app.add_option("--max-width", scene_options.max_width, "Downsample wider images to this width (0: as they are)");
  RelativePoseNoise perturb;
  app.add_option("--perturb-deg", perturb.deg,
                 "Also score the network refining cameras perturbed by this rotation (deg, per-axis std)");
  app.add_option("--perturb-translation", perturb.translation,
                 "... and this translation (per-axis std, fraction of each baseline)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (num_sources < 1) throw InputError("--sources: expected >= 1");
  if (!(perturb.deg >= 0 && perturb.deg <= 30 && perturb.translation >= 0 && perturb.translation <= 1)) {
    throw InputError("--perturb-deg / --perturb-translation: expected 0 to 30 degrees and 0 to 1");
  }
  const torch::Device dev = ParseDevice(device);
  CheckCanWriteOutput(out, common.force, {dataset, weights});
  DbarfModel model = LoadDbarfWeights(weights);
  model.To(dev);
  const Timer timer;
  LoadedDbarfScene loaded = LoadDbarfScene(dataset, scene_options);
  if (!loaded.ground_truth.defined()) ThrowInputError(dataset, "", "a dataset with ground-truth poses (not the output of dbarf poses)");
  const double seconds_poses = timer.Seconds();
  DbarfScene& scene = loaded.scene;

  // Poses: every posed image against the ground truth.
  std::vector<Rigid3d> est, gt;
  std::vector<bool> posed(scene.NumViews(), true);
  for (const auto& name : loaded.not_posed)
    for (int v = 0; v < scene.NumViews(); ++v)
      if (scene.image_names[v] == name) posed[v] = false;
  const auto rigid = [](const torch::Tensor& t) { return Rigid3d::FromMatrix(TensorToMatrix4(t), 1e-3); };
  for (int v = 0; v < scene.NumViews(); ++v) {
    if (!posed[v]) continue;
    est.push_back(rigid(scene.cam_from_world[v]));
    gt.push_back(rigid(loaded.ground_truth[v]));
  }
  const PoseEvaluation pe = EvaluatePoses(est, gt, PoseAlignment::kRotationsAndCenters);
  // Relative poses between each usable view and its view-graph neighbours (scale-free measures):
  // the estimated cameras', and the pose network's refinement of them.
  const RelativePoseError rel_cameras = EvaluateCameraRelativePoses(scene, loaded.ground_truth, num_sources);
  const RelativePoseError rel_network = EvaluateRelativePoses(model, scene, loaded.ground_truth, num_sources, "cameras");
  const auto rel_json = [](const RelativePoseError& e) {
    return Json{{"rotation_deg", e.rotation_deg}, {"translation_direction_deg", e.translation_deg}, {"pairs", e.pairs}};
  };
  Json relative = {{"cameras", rel_json(rel_cameras)}, {"network", rel_json(rel_network)}};
  if (perturb.Active()) {
    // What the network does with a worse initialisation than the cameras: the same perturbation
    // for both rows.
    relative["perturbed"] = {
        {"deg", perturb.deg},
        {"translation", perturb.translation},
        {"cameras", rel_json(EvaluateCameraRelativePoses(scene, loaded.ground_truth, num_sources, perturb))},
        {"network", rel_json(EvaluateRelativePoses(model, scene, loaded.ground_truth, num_sources, "cameras", perturb))}};
  }

  // Novel views: test views at their estimated cameras, from training views.
  OutputDir output(out, common.force, {dataset, weights});
  const std::string& tmp = output.tmp();
  CreateDirectories(JoinPaths(tmp, "views"));
  Json views = Json::array();
  std::vector<double> psnrs, ssims;
  std::vector<Image> sheet;
  {
    int num_test = 0;
    for (int v = 0; v < scene.NumViews(); ++v) num_test += loaded.is_test[v];
    ProgressBar bar("dbarf eval", num_test, "view");
    for (int v = 0; v < scene.NumViews(); ++v) {
      if (!loaded.is_test[v]) continue;
      bar.Tick();
      const std::string& name = scene.image_names[v];
      std::vector<int> sources = DbarfTrainer::SourcesOf(scene, v, num_sources);
      if (!posed[v] || sources.empty()) {
        views.push_back({{"name", name}, {"rendered", false}});
        LOG_WARN("{}: test view {} not posed or without training neighbours; not rendered", dataset, name);
        continue;
      }
      const int64_t h = scene.images.size(2), w = scene.images.size(3);
      const NovelView nv = RenderNovelView(model, scene, sources, scene.intrinsics[v], scene.cam_from_world[v], h, w);
      const Image render = TensorToImage(nv.rgb), truth = TensorToImage(scene.images[v]);
      const double psnr = Psnr(render, truth), ssim = Ssim(render, truth);
      psnrs.push_back(psnr);
      ssims.push_back(ssim);
      const std::string png = fs::path(name).replace_extension(".png").string();
      WriteImage(JoinPaths(tmp, "views/" + png), render);
      const Image depth = DepthImage(nv.depth, nv.valid, scene.near, scene.far);
      WriteImage(JoinPaths(tmp, "views/depth_" + png), depth);
      sheet.insert(sheet.end(), {truth, render, depth});
      views.push_back({{"name", name}, {"rendered", true}, {"psnr", psnr}, {"ssim", ssim}, {"sources", sources.size()}});
    }
    bar.Finish();
    const auto mean = [](const std::vector<double>& x) {
      double s = 0;
      for (double v : x) s += v;
      return x.empty() ? 0.0 : s / x.size();
    };
    const Json result = {{"dataset", dataset},
                         {"weights", weights},
                         {"images", scene.NumViews()},
                         {"posed", est.size()},
                         {"not_posed", loaded.not_posed},
                         {"rotation_deg_median", pe.aligned ? pe.median_rotation_deg : -1.0},
                         {"rotation_deg_mean", pe.aligned ? pe.mean_rotation_deg : -1.0},
                         {"center_median", pe.aligned ? pe.median_center : -1.0},
                         {"center_percent_median", pe.aligned ? pe.median_center_percent : -1.0},
                         {"relative_poses", relative},
                         {"test_views", views.size()},
                         {"rendered", psnrs.size()},
                         {"psnr_mean", mean(psnrs)},
                         {"ssim_mean", mean(ssims)},
                         {"seconds_poses", seconds_poses},
                         {"seconds", timer.Seconds()},
                         {"views", views},
                         {"protocol", "test views rendered at their estimated cameras (posed from all images), "
                                      "from view-graph neighbours among the training views"}};
    WriteJsonFile(JoinPaths(tmp, "eval.json"), result);
    if (!sheet.empty()) WriteImage(JoinPaths(tmp, "compare.png"), ContactSheet(sheet, 3));
    output.Commit();
    if (common.json) {
      std::printf("%s\n", result.dump().c_str());
    } else {
      std::printf("posed              %zu / %lld\n", est.size(), static_cast<long long>(scene.NumViews()));
      std::printf("rotation (deg)     median %.4f  mean %.4f\n", pe.median_rotation_deg, pe.mean_rotation_deg);
      std::printf("centre             median %.5f  (%.3f %% of the widest baseline)\n", pe.median_center,
                  pe.median_center_percent);
      std::printf("relative poses     cameras %.4f deg / direction %.3f deg; network %.4f / %.3f deg (%d pairs)\n",
                  rel_cameras.rotation_deg, rel_cameras.translation_deg, rel_network.rotation_deg,
                  rel_network.translation_deg, rel_network.pairs);
      std::printf("novel views        %zu rendered: PSNR %.2f dB  SSIM %.4f\n", psnrs.size(), mean(psnrs), mean(ssims));
      std::printf("time               %.1f s (poses %.1f s)\n", timer.Seconds(), seconds_poses);
    }
  }
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
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (num_sources < 1) throw InputError("--sources: expected >= 1, got " + std::to_string(num_sources));
  DbarfModel model = LoadDbarfWeights(weights);
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
