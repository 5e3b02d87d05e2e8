#include "nerfreg/dbarf_data/train_dbarf.h"

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf_data/posed_images.h"
#include "nerfreg/dist/dist.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"

namespace nerfreg {

namespace {

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

// The scenes to train on; a dataset's own poses, kept apart from the estimated cameras, are read
// only by the supervised pose loss and the log's error columns.
std::vector<DbarfScene> TrainingScenes(const DbarfTrainingJob& c, const std::vector<LoadedDbarfScene>& loaded) {
  std::vector<DbarfScene> scenes;
  for (size_t i = 0; i < loaded.size(); ++i) {
    scenes.push_back(loaded[i].scene);
    if ((c.train.supervise_poses > 0 || c.train.supervise_depth > 0) && !loaded[i].ground_truth.defined()) {
      ThrowInputError(c.scenes[i], "poses",
                      "a dataset with ground-truth poses (--supervise-poses), not dbarf poses output");
    }
    if (loaded[i].ground_truth.defined()) {
      scenes.back().supervision_cam_from_world = GroundTruthInEstimatedScale(
          loaded[i].ground_truth, loaded[i].scene.cam_from_world, loaded[i].scene.usable, c.scenes[i]);
    }
  }
  return scenes;
}

}  // namespace

DbarfTrainingResult TrainDbarf(DbarfTrainingJob c) {
  std::vector<std::string> inputs = c.scenes;
  inputs.push_back(c.weights);
  if (!c.run.resume) CheckCanWriteOutput(c.run.out, c.force, inputs);
  c.train.Check();
  c.run.Check();
  // Weights and state first: a wrong file fails before minutes of scene loading.
  if (c.run.resume && !FileExists(c.run.out + ".train")) {
    ThrowInputError(c.run.out + ".train", "", "a training state to resume (written by dbarf pretrain / finetune)");
  }
  DbarfOptions expected = DbarfOptions::Named(c.config);
  if (c.rotation_scale > 0) expected.pose.rotation_scale = c.rotation_scale;
  // A fresh network's initialisation draws from torch's generator: seeded, so a run repeats.
  torch::manual_seed(c.train.seed);
  DbarfModel model = c.run.resume ? LoadDbarfWeights(c.run.out, &expected)
                                  : (c.weights.empty() ? DbarfModel(expected) : LoadDbarfWeights(c.weights));
  if (!c.run.resume && !c.weights.empty() && c.rotation_scale > 0) {
    model.pose_net->SetRotationScale(c.rotation_scale);
    model.options.pose.rotation_scale = c.rotation_scale;
  }
  if (c.fresh_pose_heads && !c.run.resume) {
    if (c.weights.empty()) throw InputError("--fresh-pose-heads: expected --weights whose encoders to keep");
    model.pose_net->ReinitialiseHeads();
  }
  const std::vector<LoadedDbarfScene> loaded = LoadScenes(c.scenes, c.scene);
  if (!c.cameras_out.empty() && loaded[0].estimated_here) {
    ThrowInputError(c.scenes[0], "dbarf_poses",
                    "posed images written by dbarf poses (--refine-cameras refines their cameras)");
  }
  const std::vector<DbarfScene> scenes = TrainingScenes(c, loaded);
  if (!c.run.resume) {
    model.training = Json::object();
    model.training["kind"] = c.kind;
    model.training["pose_init"] = c.train.pose_init;
    model.training["supervise_poses"] = c.train.supervise_poses;
    model.training["supervise_depth"] = c.train.supervise_depth;
    if (c.train.blur_probability > 0) model.training["augment_blur"] = c.train.blur_probability;
    if (!c.weights.empty()) model.training["initial_weights"] = c.weights;
    if (c.fresh_pose_heads) model.training["fresh_pose_heads"] = true;
  }
  model.training["data"] = c.scenes;
  DbarfTrainingResult out;
  out.run = RunDbarfTraining(&model, scenes, c.train, c.run, c.group);
  const DbarfRunResult& r = out.run;
  out.summary = {{"steps", r.steps},
                 {"seconds", r.seconds},
                 {"psnr_train_last", r.mean_psnr_last},
                 {"sfm_loss_last", r.mean_sfm_last},
                 {"weights", c.run.out},
                 {"scenes", c.scenes.size()},
                 {"processes", c.group != nullptr ? c.group->world_size() : 1}};
  if (c.group != nullptr && !c.group->is_main()) return out;
  if (!c.cameras_out.empty()) {
    // The input's posed images with every frame's camera replaced by the refined one.
    torch::Tensor cameras = r.cameras[0];  // [V, 4, 4]
    if (c.depth_refinement.rounds > 0) {
      const RenderedDepthRefinementResult d =
          RefineCamerasWithRenderedDepths(model, scenes[0], cameras, c.depth_refinement);
      cameras = d.cam_from_world;
      out.summary["depth_ba"] = {{"rounds", c.depth_refinement.rounds},
                                 {"sources", c.depth_refinement.num_sources},
                                 {"view_range_margin", c.depth_refinement.view_range_margin},
                                 {"pairs", d.pairs},
                                 {"photometric_error_before", d.initial_loss},
                                 {"photometric_error_after", d.final_loss},
                                 {"seconds", d.seconds}};
    }
    Dataset refined = loaded[0].dataset;
    for (size_t k = 0; k < refined.frames.size(); ++k) {
      refined.frames[k].cam_from_world = Rigid3d::FromMatrix(TensorToMatrix4(cameras[static_cast<int64_t>(k)]), 1e-3);
    }
    WriteRefinedPosedImages(c.scenes[0], refined, c.cameras_out);
    LOG_INFO("refined cameras -> {}", c.cameras_out);
  }
  WriteJsonFile(c.run.out + ".json", out.summary);
  LOG_INFO("{}: {} steps in {:.1f} s, training PSNR (last 10%) {:.2f} dB -> {}", c.kind, r.steps, r.seconds,
           r.mean_psnr_last, c.run.out);
  return out;
}

}  // namespace nerfreg
