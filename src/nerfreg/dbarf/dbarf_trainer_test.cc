#include "nerfreg/dbarf/dbarf_trainer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <ATen/CPUGeneratorImpl.h>

#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/test_scene.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

using testing_scene::PlaneScene;

// Four views of the analytic ridge: view 0 at the identity, views 1-3 at known offsets; every view
// neighbours every other.
DbarfScene RidgeScene(torch::Tensor* true_cam_from_world) {
  const PlaneScene ridge = PlaneScene::Ridge(2.0, 0.4, 48, 64);
  const torch::Tensor poses = torch::cat({torch::eye(4).unsqueeze(0), testing_scene::SourcePoses(3)}, 0);
  DbarfScene scene;
  scene.name = "ridge";
  std::vector<torch::Tensor> images;
  for (int v = 0; v < 4; ++v) {
    images.push_back(ridge.Render(poses[v]));
    scene.image_names.push_back("v" + std::to_string(v) + ".png");
    std::vector<int> n;
    for (int j = 0; j < 4; ++j)
      if (j != v) n.push_back(j);
    scene.neighbours.push_back(n);
    scene.usable.push_back(true);
  }
  scene.images = torch::cat(images, 0);
  scene.intrinsics = ridge.intrinsics.unsqueeze(0).repeat({4, 1, 1});
  scene.near = 1.0;
  scene.far = 8.0;
  *true_cam_from_world = poses;
  return scene;
}

DbarfTrainOptions SmallOptions() {
  DbarfTrainOptions o;
  o.num_sources = 3;
  o.source_jitter_min = o.source_jitter_max = 0;
  o.self_source_probability = 0;
  o.rays_per_step = 64;
  return o;
}

std::vector<torch::Tensor> Snapshot(const std::vector<torch::Tensor>& params) {
  std::vector<torch::Tensor> out;
  for (const auto& p : params) out.push_back(p.detach().clone());
  return out;
}

bool Changed(const std::vector<torch::Tensor>& before, const std::vector<torch::Tensor>& params) {
  for (size_t i = 0; i < params.size(); ++i)
    if (!torch::equal(before[i], params[i].detach())) return true;
  return false;
}

TEST(DbarfTrainer, StageScheduleFollowsTheOriginal) {
  const std::vector<DbarfStage> expected = {DbarfStage::kPose,  DbarfStage::kNerf, DbarfStage::kPose,
                                            DbarfStage::kJoint, DbarfStage::kPose, DbarfStage::kNerf,
                                            DbarfStage::kJoint, DbarfStage::kNerf};
  for (size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(DbarfStageOfStep(static_cast<int64_t>(k) * 100 + 99, 100), expected[k]) << "block " << k;
  }
}

TEST(DbarfTrainer, EachStageUpdatesOnlyItsOwnParameters) {
  torch::manual_seed(0);
  torch::Tensor truth;
  DbarfModel model(DbarfOptions::Cpu());
  DbarfTrainOptions options = SmallOptions();
  options.stage_steps = 1;  // steps 0, 1, 2, 3: pose, nerf, pose, joint
  DbarfTrainer trainer(&model, {RidgeScene(&truth)}, options);
  const std::vector<DbarfStage> stages = {DbarfStage::kPose, DbarfStage::kNerf, DbarfStage::kPose, DbarfStage::kJoint};
  for (DbarfStage stage : stages) {
    const auto nerf_before = Snapshot(model.NerfParameters());
    const auto pose_before = Snapshot(model.PoseParameters());
    const DbarfStepResult r = trainer.Step();
    ASSERT_EQ(r.stage, stage);
    const bool nerf_changed = Changed(nerf_before, model.NerfParameters());
    const bool pose_changed = Changed(pose_before, model.PoseParameters());
    EXPECT_EQ(nerf_changed, stage != DbarfStage::kPose) << DbarfStageName(stage);
    EXPECT_EQ(pose_changed, stage != DbarfStage::kNerf) << DbarfStageName(stage);
    if (stage != DbarfStage::kNerf) EXPECT_GT(r.sfm_loss, 0.0);
    if (stage != DbarfStage::kPose) EXPECT_GT(r.rgb_loss, 0.0);
  }
}

TEST(DbarfTrainer, AnUntrainedNetworkReturnsTheCamerasItStartsFrom) {
  torch::manual_seed(1);
  torch::Tensor truth;
  DbarfScene scene = RidgeScene(&truth);
  // Cameras a few degrees and centimetres off, as a classical initialisation might be.
  const torch::Tensor noise = torch::tensor({{0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
                                             {0.03, -0.02, 0.02, 0.015, -0.02, 0.01},
                                             {-0.02, 0.03, -0.01, -0.01, 0.015, 0.02},
                                             {0.02, 0.02, 0.03, 0.02, 0.01, -0.015}},
                                            torch::kFloat);
  scene.cam_from_world = torch::matmul(Se3Exp(noise), truth);
  DbarfModel model(DbarfOptions::Cpu());
  const RelativePoseError cameras = EvaluateCameraRelativePoses(scene, truth, 3);
  const RelativePoseError network = EvaluateRelativePoses(model, scene, truth, 3, "cameras");
  EXPECT_EQ(network.pairs, 12);
  EXPECT_GT(cameras.rotation_deg, 1.0);
  EXPECT_NEAR(network.rotation_deg, cameras.rotation_deg, 0.05);
  EXPECT_NEAR(network.translation, cameras.translation, 1e-3);
  // From a perturbed initialisation it returns that initialisation, the same draw as the cameras'
  // row gets.
  const RelativePoseNoise perturb{2.0, 0.1, 5};
  const RelativePoseError perturbed = EvaluateCameraRelativePoses(scene, truth, 3, perturb);
  const RelativePoseError network_perturbed = EvaluateRelativePoses(model, scene, truth, 3, "cameras", perturb);
  EXPECT_NE(perturbed.rotation_deg, cameras.rotation_deg);
  EXPECT_NEAR(network_perturbed.rotation_deg, perturbed.rotation_deg, 0.05);
  EXPECT_NEAR(network_perturbed.translation, perturbed.translation, 1e-3);
  // Without cameras it starts at the identity.
  const RelativePoseError identity = EvaluateRelativePoses(model, scene, truth, 3, "network");
  EXPECT_GT(identity.translation, 3 * cameras.translation);
  // |t| / |t_true|: the network returns the cameras' (which are off by noise), the identity's is 0;
  // the true cameras' is 1, halved translations' 0.5 (the static solution's signature is a small
  // ratio). The network's disparity is a mean inside the normalised range, the cameras' none.
  EXPECT_GT(cameras.translation_ratio, 0.5);
  EXPECT_NEAR(network.translation_ratio, cameras.translation_ratio, 1e-3);
  EXPECT_EQ(EvaluateIdentityRelativePoses(scene, truth, 3).translation_ratio, 0.0);
  EXPECT_EQ(cameras.disparity, -1.0);
  EXPECT_GE(network.disparity, 0.0);
  EXPECT_LE(network.disparity, 1.0);
  scene.cam_from_world = truth.clone();
  EXPECT_NEAR(EvaluateCameraRelativePoses(scene, truth, 3).translation_ratio, 1.0, 1e-5);
  scene.cam_from_world.slice(1, 0, 3).select(2, 3).mul_(0.5);
  EXPECT_NEAR(EvaluateCameraRelativePoses(scene, truth, 3).translation_ratio, 0.5, 1e-5);
}

TEST(DbarfTrainer, PerturbRelativePosesHasTheRequestedSpreadAndIsSeeded) {
  // 4000 copies of one pose with a 0.5 baseline.
  const torch::Tensor pose = Se3Exp(torch::tensor({{0.3, -0.2, 0.3, 0.05, 0.1, -0.02}}, torch::kFloat));
  const double baseline = pose[0].slice(0, 0, 3).select(1, 3).norm().item<double>();
  const torch::Tensor poses = pose.repeat({4000, 1, 1});
  const auto draw = [&](double deg, double translation, uint64_t seed) {
    return PerturbRelativePoses(poses, deg, translation, at::detail::createCPUGenerator(seed));
  };
  // A per-axis standard deviation s gives a Maxwell-distributed magnitude of mean 2 s sqrt(2 / pi).
  const double maxwell = 2.0 * std::sqrt(2.0 / M_PI);
  const torch::Tensor rotated = draw(2.0, 0.0, 1);
  const torch::Tensor angle = Se3Log(torch::matmul(rotated, Se3Inverse(poses))).slice(1, 3, 6).norm(2, 1);
  EXPECT_NEAR(angle.mean().item<double>() * 180.0 / M_PI, 2.0 * maxwell, 0.1 * 2.0 * maxwell);
  // Translation alone adds rho to t (a per-axis spread of 0.1 baseline) and keeps the rotation.
  const torch::Tensor shifted = draw(0.0, 0.1, 2);
  const torch::Tensor moved = (shifted.slice(1, 0, 3).select(2, 3) - poses.slice(1, 0, 3).select(2, 3)).norm(2, 1);
  EXPECT_NEAR(moved.mean().item<double>(), 0.1 * baseline * maxwell, 0.1 * 0.1 * baseline * maxwell);
  EXPECT_TRUE(torch::allclose(shifted.slice(1, 0, 3).slice(2, 0, 3), poses.slice(1, 0, 3).slice(2, 0, 3)));
  // Seeded: the same generator seed gives the same draw, another seed another.
  EXPECT_TRUE(torch::equal(draw(1.0, 0.05, 3), draw(1.0, 0.05, 3)));
  EXPECT_FALSE(torch::equal(draw(1.0, 0.05, 3), draw(1.0, 0.05, 4)));
  EXPECT_TRUE(torch::allclose(draw(0.0, 0.0, 3), poses));
}

TEST(DbarfTrainer, InitialisationNoiseReachesThePoseNetworkAndNeedsCameras) {
  torch::Tensor truth;
  DbarfScene scene = RidgeScene(&truth);
  scene.cam_from_world = truth;
  DbarfTrainOptions options = SmallOptions();
  options.pose_init = "cameras";
  // An untrained network returns its initial poses: with exact cameras and no noise the first
  // pose step's SfM loss is that of the true poses; perturbed, it is higher.
  const auto first_sfm = [&](double deg) {
    torch::manual_seed(0);
    DbarfModel model(DbarfOptions::Cpu());
    DbarfTrainOptions o = options;
    o.init_noise_deg = deg;
    DbarfTrainer trainer(&model, {scene}, o);
    return trainer.Step().sfm_loss;
  };
  EXPECT_GT(first_sfm(3.0), first_sfm(0.0));
  DbarfTrainOptions bad = options;
  bad.init_noise_deg = 1.0;
  bad.pose_init = "network";
  EXPECT_THROW(bad.Check(), InputError);
  bad.pose_init = "cameras";
  bad.init_noise_translation = 2.0;
  EXPECT_THROW(bad.Check(), InputError);
}

TEST(DbarfTrainer, CameraRefinementStepsInNerfStagesHoldsTheFrameAndResumes) {
  torch::manual_seed(2);
  torch::Tensor truth;
  DbarfScene scene = RidgeScene(&truth);
  scene.cam_from_world = truth;
  DbarfModel model(DbarfOptions::Cpu());
  DbarfTrainOptions options = SmallOptions();
  options.stage_steps = 1;  // pose, nerf, pose, joint
  options.pose_init = "cameras";
  options.refine_cameras = true;
  EXPECT_THROW(options.Check(), InputError);  // the RGB loss reaches cameras only when they place the sources
  options.nerf_poses = "cameras";
  DbarfTrainer trainer(&model, {scene}, options);
  EXPECT_TRUE(torch::allclose(trainer.Cameras(0), truth, 0, 1e-6));
  const std::vector<bool> moves = {false, true, false, false};  // only the NeRF stage steps the cameras
  for (bool expected : moves) {
    const torch::Tensor before = trainer.Cameras(0).detach().clone();
    const DbarfStepResult r = trainer.Step();
    const torch::Tensor after = trainer.Cameras(0).detach();
    EXPECT_EQ(!torch::allclose(before, after, 0, 1e-7), expected) << DbarfStageName(r.stage);
    EXPECT_TRUE(torch::allclose(after[0], truth[0], 0, 1e-6));  // view 0 fixes the frame
  }
  // The refined cameras are part of the training state.
  ScopedTempDir dir;
  trainer.SaveState(dir.File("state"));
  DbarfTrainer resumed(&model, {scene}, options);
  resumed.LoadState(dir.File("state"));
  EXPECT_TRUE(torch::equal(resumed.Cameras(0).detach(), trainer.Cameras(0).detach()));
  EXPECT_FALSE(torch::allclose(resumed.Cameras(0).detach(), truth, 0, 1e-7));
}

TEST(DbarfTrainer, WeightsAndStateRoundTripAndResumeReproducesTheNextStep) {
  const ScopedTempDir tmp;
  const std::string dir = tmp.path();
  torch::Tensor truth;
  const DbarfScene scene = RidgeScene(&truth);
  DbarfTrainOptions options = SmallOptions();
  options.stage_steps = 2;
  torch::manual_seed(2);
  DbarfModel model(DbarfOptions::Cpu());
  model.training = {{"steps", 3}};
  DbarfTrainer trainer(&model, {scene}, options);
  for (int i = 0; i < 3; ++i) trainer.Step();
  SaveDbarfWeights(model, dir + "/w.pt");
  trainer.SaveState(dir + "/w.pt.train");
  const DbarfStepResult next = trainer.Step();  // step 3: nerf stage

  const DbarfOptions cpu = DbarfOptions::Cpu();
  DbarfModel loaded = LoadDbarfWeights(dir + "/w.pt", &cpu);
  EXPECT_EQ(loaded.training["steps"], 3);
  DbarfTrainer resumed(&loaded, {scene}, options);
  resumed.LoadState(dir + "/w.pt.train");
  EXPECT_EQ(resumed.step(), 3);
  const DbarfStepResult again = resumed.Step();
  EXPECT_EQ(again.stage, next.stage);
  EXPECT_EQ(again.target, next.target);
  EXPECT_NEAR(again.rgb_loss, next.rgb_loss, 1e-6);

  // Another configuration, a foreign file, a truncated file.
  DbarfOptions other = DbarfOptions::Cpu();
  other.pose.hidden_channels = 24;
  EXPECT_THROW(LoadDbarfWeights(dir + "/w.pt", &other), InputError);
  EXPECT_THROW(LoadDbarfWeights(dir + "/w.pt.train"), InputError);
  std::filesystem::resize_file(dir + "/w.pt", std::filesystem::file_size(dir + "/w.pt") / 2);
  EXPECT_THROW(LoadDbarfWeights(dir + "/w.pt"), InputError);
  EXPECT_THROW(LoadDbarfWeights(dir + "/missing.pt"), InputError);
}

TEST(DbarfTrainer, SupervisedPoseLossVanishesAtTheTruthAndIsScaleFree) {
  const torch::Tensor truth = testing_scene::SourcePoses(3);
  EXPECT_LT(SupervisedPoseLoss({truth, truth}, truth).item<double>(), 1e-4);
  // One degree about y, and a translation off by a tenth of each baseline.
  const torch::Tensor turn =
      Se3Exp(torch::tensor({{0.0, 0.0, 0.0, 0.0, M_PI / 180.0, 0.0}}, torch::kFloat)).expand({3, 4, 4});
  torch::Tensor turned = truth.clone();  // the rotation turned, the translation kept
  turned.slice(1, 0, 3).slice(2, 0, 3).copy_(torch::matmul(turn, truth).slice(1, 0, 3).slice(2, 0, 3));
  const double chordal = 2 * std::sqrt(2.0) * std::sin(M_PI / 360.0);  // |R_a - R_b|_F a degree apart
  EXPECT_NEAR(SupervisedPoseLoss({turned}, truth).item<double>(), chordal, 1e-4);
  torch::Tensor shifted = truth.clone();
  shifted.slice(1, 0, 3).select(2, 3).mul_(1.1);
  EXPECT_NEAR(SupervisedPoseLoss({shifted}, truth).item<double>(), 0.1, 1e-4);
  // Scaling prediction and truth together leaves it unchanged.
  torch::Tensor big_truth = truth.clone(), big_shifted = shifted.clone();
  big_truth.slice(1, 0, 3).select(2, 3).mul_(7.0);
  big_shifted.slice(1, 0, 3).select(2, 3).mul_(7.0);
  EXPECT_NEAR(SupervisedPoseLoss({big_shifted}, big_truth).item<double>(), 0.1, 1e-4);
  // Earlier predictions weigh 0.85 per step back, like the SfM loss.
  EXPECT_NEAR(SupervisedPoseLoss({shifted, truth}, truth).item<double>(), 0.085, 1e-4);
  // The rotation term's weight multiplies it alone.
  EXPECT_NEAR(SupervisedPoseLoss({turned}, truth, 3.0).item<double>(), 3 * chordal, 3e-4);
  // Finite gradients at the truth.
  const torch::Tensor p = truth.clone().requires_grad_(true);
  SupervisedPoseLoss({p}, truth).backward();
  EXPECT_TRUE(torch::isfinite(p.grad()).all().item<bool>());
}

TEST(DbarfTrainer, GroundTruthIsRescaledToTheEstimatedCamerasUnits) {
  torch::Tensor truth;
  RidgeScene(&truth);
  // The estimate: the truth in another frame (a rigid motion) and 3x its scale.
  torch::Tensor scaled = truth.clone();
  scaled.slice(1, 0, 3).select(2, 3).mul_(3.0);
  const torch::Tensor frame = Se3Exp(torch::tensor({0.4, -0.2, 0.9, 0.3, -0.5, 0.2}, torch::kFloat));
  const torch::Tensor estimated = torch::matmul(scaled, Se3Inverse(frame));
  const torch::Tensor rescaled = GroundTruthInEstimatedScale(truth, estimated, {true, true, true, true}, "x");
  const std::vector<int> sources = {1, 2, 3};
  EXPECT_TRUE(
      torch::allclose(RelativeCameras(rescaled, 0, sources), RelativeCameras(estimated, 0, sources), 1e-4, 1e-4));
  EXPECT_THROW(GroundTruthInEstimatedScale(truth, estimated, {true, false, false, false}, "x"), InputError);
}

TEST(DbarfTrainer, SupervisedPosesNeedGroundTruthAndTeachPosesFromTheIdentity) {
  torch::Tensor truth;
  DbarfScene scene = RidgeScene(&truth);
  DbarfTrainOptions options = SmallOptions();
  options.stage_steps = 1000;  // pose stage only
  options.supervise_poses = 1.0;
  options.lr_pose = 1e-3;
  DbarfModel model(DbarfOptions::Cpu());
  EXPECT_THROW(DbarfTrainer(&model, {scene}, options), InputError);  // no supervision cameras
  options.supervise_poses = -1;
  EXPECT_THROW(options.Check(), InputError);
  options.supervise_poses = 1.0;
  scene.supervision_cam_from_world = truth;
  torch::manual_seed(3);
  // A smaller recurrence than the cpu config's, to keep the test short.
  DbarfOptions unscaled = DbarfOptions::Cpu();
  unscaled.pose.rotation_scale = 1.0;
  unscaled.pose.outer_iterations = 1;
  unscaled.pose.inner_iterations = 2;
  DbarfModel fresh(unscaled);
  const RelativePoseError before = EvaluateRelativePoses(fresh, scene, truth, 3, "network");
  DbarfTrainer trainer(&fresh, {scene}, options);
  DbarfStepResult first;
  double last_losses = 0;  // summed over the last 20 steps (each step sees one target)
  for (int i = 0; i < 300; ++i) {
    const DbarfStepResult r = trainer.Step();
    if (i == 0) first = r;
    if (i >= 280) last_losses += r.pose_loss;
  }
  EXPECT_GT(first.pose_loss, 0.0);
  EXPECT_GE(first.rotation_err_deg, 0.0);  // logged when the scene has supervision cameras
  EXPECT_LT(last_losses / 20, 0.5 * first.pose_loss);
  const RelativePoseError after = EvaluateRelativePoses(fresh, scene, truth, 3, "network");
  EXPECT_LT(after.rotation_deg, 0.5 * before.rotation_deg);
  EXPECT_LT(after.translation_deg, 0.5 * before.translation_deg);
}

TEST(DbarfTrainer, BoxBlurKeepsFlatImagesAndSmoothsEdges) {
  const torch::Tensor flat = torch::full({2, 3, 12, 16}, 0.25f);
  EXPECT_TRUE(torch::allclose(BoxBlur(flat, 2, 3), flat, 1e-6, 1e-6));  // edges average inside the image
  // A checkerboard of 1-pixel squares: radius 1 averages 5 of one colour with 4 of the other.
  const torch::Tensor ij = torch::arange(16).view({4, 4});
  const torch::Tensor board =
      ((torch::div(ij, 4, "floor") + ij % 4) % 2).to(torch::kFloat).view({1, 1, 4, 4}).repeat({1, 1, 3, 3});
  const torch::Tensor once = BoxBlur(board, 1, 1);
  EXPECT_EQ(once.sizes(), board.sizes());
  EXPECT_NEAR(once[0][0][5][5].item<float>(), board[0][0][5][5].item<float>() > 0.5f ? 5.0f / 9 : 4.0f / 9, 1e-6);
  EXPECT_LT(BoxBlur(board, 2, 3).std().item<float>(), 0.1 * board.std().item<float>());
  EXPECT_TRUE(torch::equal(BoxBlur(board, 0, 3), board));
}

// --augment-blur: checked, and drawn from the trainer's own stream (a run replays) only when on;
// the pose network then sees another image, so the step's SfM loss differs from the unblurred run.
TEST(DbarfTrainer, BlurAugmentationIsSeededAndChangesWhatThePoseNetworkSees) {
  torch::Tensor truth;
  DbarfScene scene = RidgeScene(&truth);
  scene.supervision_cam_from_world = truth;
  DbarfTrainOptions options = SmallOptions();
  options.stage_steps = 1000;  // pose stage only
  options.supervise_poses = 1.0;
  options.pose_init = "network";
  options.blur_probability = 1.5;
  EXPECT_THROW(options.Check(), InputError);
  const auto first_loss = [&](double blur) {
    DbarfTrainOptions o = options;
    o.blur_probability = blur;
    torch::manual_seed(5);
    DbarfModel model(DbarfOptions::Cpu());
    DbarfTrainer trainer(&model, {scene}, o);
    return trainer.Step().sfm_loss;  // through the predicted depth (a fresh network returns the identity pose)
  };
  const double plain = first_loss(0), blurred = first_loss(1), again = first_loss(1);
  EXPECT_EQ(blurred, again);
  EXPECT_NE(blurred, plain);
}

TEST(DbarfTrainer, RejectsScenesWithoutUsableNeighboursOrDepthRange) {
  torch::Tensor truth;
  DbarfModel model(DbarfOptions::Cpu());
  DbarfScene scene = RidgeScene(&truth);
  scene.far = 0.5;
  EXPECT_THROW(DbarfTrainer(&model, {scene}, SmallOptions()), InputError);
  scene = RidgeScene(&truth);
  for (auto& n : scene.neighbours) n.clear();
  EXPECT_THROW(DbarfTrainer(&model, {scene}, SmallOptions()), InputError);
  scene = RidgeScene(&truth);
  DbarfTrainOptions cams = SmallOptions();
  cams.nerf_poses = "cameras";
  EXPECT_THROW(DbarfTrainer(&model, {scene}, cams), InputError);  // the scene has no cameras
}

}  // namespace
}  // namespace nerfreg
