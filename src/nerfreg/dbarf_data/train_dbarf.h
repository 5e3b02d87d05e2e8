#pragma once
// `dbarf pretrain` / `dbarf finetune`'s job: the scenes loaded (cameras, depth range and view graph
// estimated where a dataset's poses are ground truth), the weights started or resumed, DBARF trained
// (dbarf/dbarf_trainer.h), a summary written beside the weights and, with refined cameras, the
// scene's posed images written again with them (dbarf_data/posed_images.h).
#include <string>
#include <vector>

#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/dbarf_data/rendered_depth_refinement.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct DbarfTrainingJob {
  std::string kind = "pretrain";  // pretrain or finetune: recorded in the weights
  std::vector<std::string> scenes;
  std::string config = "cpu";  // network sizes of fresh weights: cpu or paper
  std::string weights;         // weights to start from ("": a fresh network)
  std::string cameras_out;     // finetune --refine-cameras: where the refined cameras go
  // With cameras_out: after the training, the cameras bundle-adjusted through the finetuned
  // renderer's depths (dbarf_data/rendered_depth_refinement.h; rounds 0: the RGB loss's alone).
  RenderedDepthRefinementOptions depth_refinement;
  double rotation_scale = 0;  // the pose heads' rotation scale (0: the config's or the weights')
  // Keep only the encoders of `weights` and draw the pose network's heads and update blocks afresh
  // (PoseDepthNetImpl::ReinitialiseHeads): the original's start, trained encoders and fresh heads.
  bool fresh_pose_heads = false;
  bool force = false;  // replace existing outputs
  DbarfTrainOptions train;
  DbarfRunOptions run;
  DbarfSceneOptions scene;
  // The processes training together (dist/dist.h; every rank runs this job alike, rank 0 alone
  // writes), or nullptr: this process alone.
  DistGroup* group = nullptr;
};

struct DbarfTrainingResult {
  DbarfRunResult run;
  Json summary;  // what OUT.json holds
};

// Throws InputError on bad input (before any scene is loaded where it can).
DbarfTrainingResult TrainDbarf(DbarfTrainingJob job);

}  // namespace nerfreg
