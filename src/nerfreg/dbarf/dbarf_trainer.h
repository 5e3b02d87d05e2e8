// Training DBARF (spec dbarf.md 4): one step = one target view and its view-graph neighbours as
// sources; the pose/depth network predicts the target's inverse depth and every source's pose
// relative to the target, and the generalizable NeRF renders target rays from the sources placed by
// those poses (the target camera is the world frame of a step). Three stages alternate:
//   pose  : the self-supervised SfM loss trains the pose network (its optimiser only);
//   nerf  : the masked RGB loss trains the NeRF (its optimiser only), sources placed by the pose
//           network's detached last prediction (or by the scene's cameras, see nerf_poses);
//   joint : a * L_sfm + (1 - a) * L_rgb, a = 2^(-joint_decay * step), both optimisers, the RGB
//           loss reaching the pose network through the source cameras.
// Block k = step / stage_steps is joint when k > 0 and k % 3 == 0, else pose when k is even and
// nerf when odd (the original's rule). Two Adam optimisers (NeRF: feature / MLP groups; pose), each
// with a step decay, each stepping only in its stages.
//
// Source views come from the view graph (never from ground-truth poses), at training and test time.
//
// A step may take several targets (samples_per_step), their gradients averaged; over several
// processes (a DistGroup, `--nproc`) each takes its share of them and the gradients are all-reduced
// as DDP does, so N processes compute what one process computes with the same samples per step.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/sfm_loss.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

class DistGroup;

// One scene as training and rendering need it (all views share one image size).
struct DbarfScene {
  std::string name;                      // for logs and errors
  std::vector<std::string> image_names;  // one per view
  torch::Tensor images;                  // [V, 3, H, W] float32 in [0, 1]
  torch::Tensor intrinsics;              // [V, 3, 3] float32, pixels of the H x W images
  // [V, 4, 4] float32: cameras estimated from the images (dbarf poses), or undefined. Never ground
  // truth: evaluation reads that separately.
  torch::Tensor cam_from_world;
  // Per view, its view-graph neighbours, most inliers first.
  std::vector<std::vector<int>> neighbours;
  // Views that may be used (targets and sources); held-out views are false.
  std::vector<bool> usable;
  double near = 0, far = 0;  // depth range of the content, scene units
  // [V, 4, 4] float32 or undefined: GROUND-TRUTH cameras, rescaled to the estimated cameras' units
  // (GroundTruthInEstimatedScale), read ONLY by the supervised pose loss of training
  // (DbarfTrainOptions::supervise_poses, a departure from the self-supervised original) and by the
  // training log's error columns (no gradient). Nothing else (view selection, initial poses,
  // rendering, depth range) may read it.
  torch::Tensor supervision_cam_from_world;

  int64_t NumViews() const { return images.defined() ? images.size(0) : 0; }
  // Throws InputError naming the scene when sizes disagree, the depth range is invalid, or no
  // usable view has a usable neighbour.
  void Check() const;
};

// [N, C, H, W] -> the same, each channel box-filtered `passes` times with a (2 radius + 1)^2 window,
// edges averaged over the pixels inside the image (close to a Gaussian after three passes).
torch::Tensor BoxBlur(const torch::Tensor& images, int radius, int passes);

enum class DbarfStage { kPose, kNerf, kJoint };
const char* DbarfStageName(DbarfStage stage);
DbarfStage DbarfStageOfStep(int64_t step, int64_t stage_steps);

struct DbarfTrainOptions {
  int64_t stage_steps = 10000;  // steps per stage block
  int num_sources = 5;          // sources per step before the jitter
  int source_jitter_min = -2;   // num_sources + uniform integer in [min, max]
  int source_jitter_max = 2;
  double self_source_probability = 0.005;  // one source replaced by the target itself
  int64_t rays_per_step = 500;             // rays per step at 5 sources (scaled by 5 / N, spec 4)
  double lr_feature = 1e-3, lr_mlp = 5e-4, lr_pose = 2e-5;
  int64_t lr_decay_steps = 50000;  // StepLR period
  double lr_gamma = 0.5;
  double joint_decay = 1e-5;  // a = 2^(-joint_decay * step)
  // Where the NeRF-only stage places the sources: "network" (the pose network's prediction, the
  // original) or "cameras" (the scene's estimated cameras, when it has them).
  std::string nerf_poses = "network";
  // Where the pose network starts: "network" (its own initial head, the original) or "cameras"
  // (the scene's estimated cameras, which the network then refines: the classical initialisation
  // keeps the self-supervised loss in its basin, where from scratch it collapses depth to the far
  // bound on small scenes).
  std::string pose_init = "network";
  // "dbarf": the stage rule above; "nerf": the NeRF-only stage throughout (the renderer alone, on
  // the scene's cameras or the network's poses as nerf_poses says).
  std::string schedule = "dbarf";
  // Pose stages with pose_init "cameras": each source's initial relative pose is perturbed by a
  // random twist (PerturbRelativePoses), so that the network sees initial errors and learns to
  // correct them from its cost maps. Without it, cameras that are already nearly right teach it
  // to output zero corrections. 0: no perturbation.
  double init_noise_deg = 0;
  double init_noise_translation = 0;
  // Also refine each scene's cameras, BARF-style: one SE(3) twist per image (the first usable
  // image's held at zero: it fixes the frame), optimised by the RGB loss of the NeRF stages, whose
  // sources the cameras place (so it needs nerf_poses "cameras"). Its own Adam, lr_cameras with the
  // same step decay. The rendering loss pulls a camera that is a degree or more off towards the
  // others; it does not sharpen cameras already more exact than its noise floor at these image
  // sizes (docs/notes/2026-11-23-dbarf-pose-network.md, "Camera refinement").
  bool refine_cameras = false;
  double lr_cameras = 3e-4;
  // Weight of the supervised pose loss (a departure from the original, which is self-supervised
  // only; 0 = off): in pose and joint stages, every prediction k of the pose network is compared
  // with the scene's supervision_cam_from_world relative poses and weighted like the SfM loss
  // (0.85^(K-1-k)): chordal rotation distance |R_pred - R_true|_F plus the translation error
  // relative to the baseline, |t_pred - t_true| / |t_true|. The ground truth is rescaled to the
  // estimated cameras' units, in which the depth range (and so the network's depth) is expressed,
  // so the term fixes the scale that the photometric loss leaves free. Needs scenes with
  // supervision cameras.
  double supervise_poses = 0;
  // Weight of the rotation term within that loss, relative to the translation term: the chordal
  // distance is about the angle in radians, as the relative translation error is about the
  // direction error, and rotations need to be ~5x more exact than directions (1 deg vs 5 deg).
  double supervise_rotation_weight = 5;
  // Weight of a second SfM loss on the predicted depths with the sources warped by the TRUE relative
  // poses (supervision_cam_from_world; a departure like supervise_poses, 0 = off): the depth gets
  // a photometric signal in the estimated cameras' units while the predicted poses are still
  // wrong, instead of retreating to the far bound (where a wrong translation costs least).
  double supervise_depth = 0;
  // Probability per step that the pose network sees the target image box-blurred (radius drawn in
  // 1..blur_max_radius, three passes; the losses keep the sharp image): user photos have defocus
  // and motion blur that renders never do, and a blurred image is the one SIFT cannot match, i.e.
  // the one `dbarf poses --method auto` hands to the network. 0 = off (no random draw either, so
  // runs without it replay as before).
  double blur_probability = 0;
  int blur_max_radius = 4;
  // The SfM loss's options (smoothness weight, auto-masking, ...): the original's by default.
  SfmLossOptions sfm;
  uint64_t seed = 0;
  // Targets per step (`--batch`), each with its own sources and rays, the gradients averaged over
  // them; 0: one per process. Each target's draws come from its own seed, drawn from the step's
  // random state, so a target is drawn alike by whichever process trains on it.
  int samples_per_step = 0;

  static DbarfTrainOptions Pretrain();
  // Finetuning on one scene: 10 sources (-2..+1), lower rates, faster decay (spec 4).
  static DbarfTrainOptions Finetune();
  void Check() const;  // throws InputError naming the option
};

struct DbarfStepResult {
  DbarfStage stage = DbarfStage::kPose;
  double sfm_loss = 0;   // 0 when not computed
  double rgb_loss = 0;   // 0 when not computed
  double pose_loss = 0;  // the supervised pose loss (unweighted); 0 when not computed
  // Monitoring of the pose network's last prediction (no gradient; < 0 when not computed): mean
  // normalised disparity of the target (0 = the far bound, 1 = the near bound), and, when the scene
  // has supervision cameras, the mean rotation error, translation-direction error and
  // sum |t| / sum |t_true| over the sources.
  double disparity = -1;
  double rotation_err_deg = -1, direction_err_deg = -1, translation_ratio = -1;
  double psnr = 0;  // of the rendered rays (nerf and joint stages)
  int scene = 0, target = 0, num_sources = 0;
};

class DbarfTrainer {
 public:
  // group: the processes training together (rank 0's parameters are copied to every rank here);
  // nullptr: this process alone. Every rank passes the same scenes and options.
  DbarfTrainer(DbarfModel* model, std::vector<DbarfScene> scenes, const DbarfTrainOptions& options,
               DistGroup* group = nullptr);
  ~DbarfTrainer();

  DbarfStepResult Step();
  int64_t step() const { return step_; }
  const std::vector<DbarfScene>& scenes() const { return scenes_; }
  int samples_per_step() const { return samples_per_step_; }
  const DistGroup& group() const { return *group_; }

  // Optimiser states, step and random state, atomically; Load throws InputError naming the file.
  void SaveState(const std::string& path) const;
  void LoadState(const std::string& path);

  // The sources of `target` in `scene`: its usable view-graph neighbours, best first, at most `k`.
  static std::vector<int> SourcesOf(const DbarfScene& scene, int target, int k);

  // Scene s's cameras [V, 4, 4] as training uses them: refined when refine_cameras, else the
  // scene's own (undefined when it has none).
  torch::Tensor Cameras(int s) const;

 private:
  // One target of the step, drawn from `seed`: forward, loss scaled by `weight`, backward (the
  // gradients accumulate); the step's optimisers are not stepped here. `rgb_valid`: whether the
  // NeRF rendered a valid ray; `touched`: the (scene, view) whose cameras it used.
  DbarfStepResult TrainOnSample(uint64_t seed, DbarfStage stage, double weight, bool* rgb_valid,
                                std::vector<std::pair<int, int>>* touched);

  DbarfModel* model_;
  std::vector<DbarfScene> scenes_;
  DbarfTrainOptions options_;
  std::unique_ptr<DistGroup> single_;  // the group when none is given
  DistGroup* group_ = nullptr;
  int samples_per_step_ = 1;
  std::vector<torch::Tensor> parameters_;  // the NeRF's and the pose network's, all-reduced each step
  std::unique_ptr<torch::optim::Adam> nerf_optimizer_, pose_optimizer_, camera_optimizer_;
  std::vector<torch::Tensor> camera_twists_;  // per scene [V, 6] when refine_cameras
  std::vector<torch::Tensor> camera_masks_;   // per scene [V, 1]: 0 for the frame's image
  int64_t step_ = 0;
  std::mt19937_64 rng_;
  std::vector<std::pair<int, int>> targets_;  // (scene, view) with at least one usable neighbour
};

// A training run: `steps` steps in total (counting those of a resumed run), progress bar, a JSON
// line per step in out + ".log.jsonl", weights (out) and state (out + ".train") every
// checkpoint_every steps and at the end, both atomic. With resume, the state in out + ".train" is
// loaded first (the caller loads the weights from out). A non-finite loss stops the run with an
// error naming the step; the last checkpoint is left as it was.
struct DbarfRunOptions {
  int64_t steps = 1000;
  int64_t checkpoint_every = 250;
  std::string out;
  bool resume = false;
  // Where the model and the scenes' tensors live during the run (`--device`).
  torch::Device device = torch::kCPU;
  void Check() const;  // throws InputError naming the option
};
struct DbarfRunResult {
  int64_t steps = 0;
  double seconds = 0;                  // this run's wall time
  double mean_psnr_last = 0;           // over the last 10% of the steps that rendered
  double mean_sfm_last = 0;            // over the last 10% of the steps with an SfM loss
  std::vector<torch::Tensor> cameras;  // per scene [V, 4, 4] as trained (refined with refine_cameras)
};
// With a group of several processes, rank 0 alone writes the log and the checkpoints; every rank
// resumes from them.
DbarfRunResult RunDbarfTraining(DbarfModel* model, std::vector<DbarfScene> scenes, const DbarfTrainOptions& options,
                                const DbarfRunOptions& run, DistGroup* group = nullptr);

// The supervised pose loss of one step (see DbarfTrainOptions::supervise_poses): predictions
// src_from_tgts[k] [N, 4, 4], truth [N, 4, 4] in the same units -> scalar, sum over k of
// prediction_decay^(K-1-k) * mean over the N poses of (rotation_weight |R_k - R|_F + |t_k - t| / |t|).
torch::Tensor SupervisedPoseLoss(const std::vector<torch::Tensor>& src_from_tgts, const torch::Tensor& truth,
                                 double rotation_weight = 1.0, double prediction_decay = 0.85);

// Ground-truth cameras [V, 4, 4] rescaled into the units of the estimated ones [V, 4, 4]: every
// translation times s, s = RMS spread of the estimated camera centres about their mean over that of
// the true centres (over the views flagged in `use`; their Sim(3) alignment's scale when the
// estimate is good). Relative poses of the result compare directly with the estimated cameras'.
// Throws InputError naming `source` when fewer than 2 views are used or the true centres coincide.
torch::Tensor GroundTruthInEstimatedScale(const torch::Tensor& true_cam_from_world,
                                          const torch::Tensor& estimated_cam_from_world, const std::vector<bool>& use,
                                          const std::string& source);

// src_from_tgt [N, 4, 4] of views `sources` relative to `target` from the scene's cameras.
// The scene with its tensors on `device`.
DbarfScene DbarfSceneTo(const DbarfScene& scene, const torch::Device& device);

torch::Tensor RelativeCameras(const torch::Tensor& cam_from_world, int target, const std::vector<int>& sources);

// src_from_tgt [N, 4, 4] moved by a random twist per pose: a rotation about a random axis whose
// per-axis components have standard deviation `deg` degrees, and a translation whose per-axis
// standard deviation is `translation` times that pose's baseline |t| (scale-free). Draws from
// `generator` (the global one when undefined).
torch::Tensor PerturbRelativePoses(const torch::Tensor& src_from_tgt, double deg, double translation,
                                   c10::optional<at::Generator> generator = c10::nullopt);

// A fixed perturbation of the initial relative poses for evaluation: the same draw for the
// cameras' error and the network's refinement of them.
struct RelativePoseNoise {
  double deg = 0;
  double translation = 0;
  uint64_t seed = 0;
  bool Active() const { return deg > 0 || translation > 0; }
};

struct RelativePoseError {
  double rotation_deg = 0;  // mean geodesic angle
  double translation = 0;   // mean |t_pred - t_true| (scene units)
  // Mean angle between predicted and true translation directions: the photometric loss fixes a
  // translation only up to the scale of the depth, so this is what self-supervision can recover.
  double translation_deg = 0;
  // sum |t_pred| / sum |t_true| over the pairs: the static (collapsed) solution has a few %, the
  // identity 0. Meaningful where the truth is in the units of the scene's depth range.
  double translation_ratio = 0;
  // The network's mean normalised target disparity (0 = the far bound, 1 = the near bound), over the
  // targets; -1 where no network predicted (the identity, the cameras).
  double disparity = -1;
  int pairs = 0;
};
// The pose network's last prediction for every usable target and its sources, against the relative
// poses of `true_cam_from_world` [V, 4, 4] (same units as the scene's depth range).
// With `pose_init` "cameras" the network starts from the scene's cameras (as in training).
RelativePoseError EvaluateRelativePoses(DbarfModel& model, const DbarfScene& scene,
                                        const torch::Tensor& true_cam_from_world, int num_sources,
                                        const std::string& pose_init = "network", const RelativePoseNoise& noise = {});
// The error of identity relative poses (the start of pose_init "network"), measured the same way:
// the rotation error is the true relative rotation; the direction of a zero translation counts 90 deg.
RelativePoseError EvaluateIdentityRelativePoses(const DbarfScene& scene, const torch::Tensor& true_cam_from_world,
                                                int num_sources);
// The error of the scene's own cameras, measured the same way (what the network should improve on).
RelativePoseError EvaluateCameraRelativePoses(const DbarfScene& scene, const torch::Tensor& true_cam_from_world,
                                              int num_sources, const RelativePoseNoise& noise = {});

}  // namespace nerfreg
