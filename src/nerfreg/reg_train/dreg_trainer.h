#pragma once
// Training the DReg-NeRF network (`nerfreg reg train`, spec dreg-nerf.md 5): one pair per step
// (batch 1, as the paper; --batch B averages B pairs' gradients), AdamW, StepLR, gradient-norm clipping, augmentation
// (random source / target swap, keypoint jitter, a rigid move of one grid with the ground truth updated; and ours: both
// grids mirrored or recoloured alike); validation on the held-out ("val") pairs by registration error; checkpoints
// written atomically with the optimizer and RNG state so `--resume` continues the same run.
//
// Data parallel (`--nproc N`, dist/): each of N processes takes every N-th pair of each global
// batch; every pair's draw (which pair, its augmentation, its jitter noise) comes from the one
// seeded stream all ranks advance alike, and gradients are summed over ranks and divided by the
// batch's pair count, so N processes compute the step one process computes with the same batch.
// Rank 0 alone writes the files below; every rank reads OUT.train on --resume.
//
// Files: OUT (the weights alone: small, what `reg register --weights` reads and what the repo
// ships), OUT.train (weights + optimizer + step + RNG: what --resume reads), OUT.log.jsonl (the
// curves), OUT.json (the summary: options, data, steps, seconds, validation table).
#include <string>
#include <vector>

#include "nerfreg/dist/dist.h"
#include "nerfreg/reg/dreg_loss.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg_train/pairs.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct DregTrainOptions {
  std::string config = "cpu";  // "cpu" or "paper" (DregModelOptions)
  int iterations = 20000;
  int batch = 0;     // pairs per step over all processes; 0: one per process
  double lr = 1e-4;  // AdamW (paper)
  double weight_decay = 1e-4;
  int lr_step = 8000;  // StepLR period (paper: 34k of 131k iterations)
  double lr_gamma = 0.5;
  double grad_clip = 0.1;                         // gradient-norm clip (paper)
  double jitter = 0.005;                          // keypoint xyz noise, scene units (paper)
  double move_probability = 0.5;                  // chance of moving one grid rigidly (resampled) per step
  double move_deg = 10, move_translation = 0.06;  // its size (paper: ~10 deg, 0.06)
  bool swap = true;                               // random source / target swap
  // Both grids mirrored (x -> -x about each grid's centre; the ground truth conjugated, still a
  // rotation) and both recoloured alike (a random permutation of R, G, B and gains in [0.7, 1.3]),
  // each with this chance per step: a mirrored or recoloured object is another plausible object.
  // Not in the paper, which trains on ~1000 objects; here ~50 real objects are drawn hundreds of
  // times each, and the network fits them far better than held-out objects (stage 7 in
  // docs/notes/2026-11-24-dreg-stages.md).
  double mirror_probability = 0, colour_probability = 0;
  double nerf_fraction = 0.0;  // chance per step of drawing a real-NeRF pair (when any): 0 = by count
  int val_every = 500;         // validation every n steps (0: only at the end)
  int max_val_pairs = 24;
  int checkpoint_every = 100;
  int stop_after = 0;          // > 0: checkpoint and return at this step
  double inlier_radius = 0.1;  // Register's confidence radius, scene units
  unsigned seed = 0;
  // Non-empty: start from these weights (reg train's OUT or the shipped file; their config must be
  // `config`) with a fresh optimizer and step 0: fine-tuning. The run keeps their options; with
  // --resume the state's weights replace them.
  std::string init_weights;
  DregLossOptions loss;
  // Where the network trains (`--device`); grids stay on the CPU and the network moves them.
  torch::Device device = torch::kCPU;
  void Check() const;  // throws InputError naming the option
  Json ToJson() const;
};

struct DregValResult {
  double median_rotation_deg = 0, mean_rotation_deg = 0, median_translation = 0;
  double success_rate = 0;  // <= 5 deg and <= 0.05 of the extent 2.5
  int pairs = 0;
  Json ToJson() const;
};

struct DregTrainResult {
  int iterations = 0;
  double seconds = 0;
  double final_loss = 0;
  DregValResult val;
};

// pairs_files: one or more pairs.json of `reg make-data`; pairs of split "train" are trained on,
// "val" ones validate, others ("test") are left out (split over the ranks). `group`: this process's place in a
// data-parallel job (null: a single process). Throws InputError on bad data; std::runtime_error on a NaN loss (the last
// good checkpoint is kept).
// Registers each pair with `net` (the network alone, Register's solve) and scores it against the
// truth: rank r of `group` registers every world-th pair and all ranks read the summed table. What
// `reg train` validates with, and what scores a held-out set.
DregValResult EvaluateDreg(DregNet& net, const std::vector<PairRecord>& pairs, double inlier_radius, DistGroup& group);

DregTrainResult TrainDreg(const std::vector<std::string>& pairs_files, const DregTrainOptions& options,
                          const std::string& out, bool resume, DistGroup* group = nullptr);

}  // namespace nerfreg
