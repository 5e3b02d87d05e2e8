#pragma once
// `dbarf eval`'s job: the pose-free pipeline against ground truth. Every image of a dataset (train
// and test split) is posed from the images alone; poses are scored after a Sim(3) alignment and,
// scale-free, as relative poses to view-graph neighbours (the estimated cameras' and the pose
// network's refinement of them); each test view is rendered at its ESTIMATED camera from its
// view-graph neighbours among the training views and scored by PSNR / SSIM. Writes OUT/eval.json,
// OUT/views/ (renders, inverse depth) and OUT/compare.png, all moved into place at once.
#include <string>

#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/sfm/pose_evaluation.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct DbarfEvaluationOptions {
  std::string dataset;  // a dataset with ground-truth poses and a test split
  std::string out;      // output folder
  std::string weights;  // DBARF weights
  int num_sources = 8;  // source views per rendered view
  DbarfSceneOptions scene;
  // `--cameras`: a transforms.json written by `dbarf poses` (or `dbarf finetune --refine-cameras`)
  // for the dataset's images: its cameras, view graph and depth range are evaluated instead of
  // estimating them here, so every pose method is scored by the same protocol. Empty: estimate.
  std::string cameras;
  // Also score the network refining cameras perturbed by this much (inactive: zero).
  RelativePoseNoise perturb;
  torch::Device device = torch::kCPU;  // where the networks run (`--device`)
  bool force = false;                  // replace an existing output
  void Check() const;                  // throws InputError naming the flag
};

struct DbarfEvaluation {
  Json json;             // what OUT/eval.json holds
  PoseEvaluation poses;  // absolute poses after the alignment (as measured, even when not aligned)
  RelativePoseError relative_cameras, relative_network;
  int64_t images = 0;
  size_t posed = 0, rendered = 0;
  double psnr_mean = 0, ssim_mean = 0;
  // Median over the rendered test views of their depth error (DepthError in evaluate_dbarf.cc),
  // where the dataset has depth maps (`render --depth`); -1 otherwise.
  double depth_error_median = -1;
  double seconds = 0, seconds_poses = 0;
};

// Throws InputError on bad input; writes nothing then.
DbarfEvaluation EvaluateDbarf(const DbarfEvaluationOptions& options);

}  // namespace nerfreg
