#pragma once
// Training a NeRF block from a posed image dataset (instant-NGP recipe, spec dreg-nerf.md 2):
// rays sampled across all training images, a ray batch sized to a target sample count, random
// background colours for RGBA images, smooth-L1 loss, Adam (lr 1e-2, eps 1e-15) with lr x0.33 at
// 50 / 75 / 90 % of the run, occupancy-grid updates every 16 steps. Checkpoints are atomic and
// carry the optimizer and RNG state so `resume` continues the same run exactly.
#include <functional>
#include <string>

#include "nerfreg/nerf/nerf_block.h"

namespace nerfreg {

struct NerfTrainOptions {
  std::string preset = "fast";  // "fast" (2 CPU cores) or "default" (the paper's)
  int iterations = 2000;
  std::int64_t target_samples = 1 << 16;  // samples per batch (paper: 2^18)
  int initial_rays = 1024;
  int max_rays = 1 << 14;
  double lr = 1e-2;
  int eval_every = 500;        // held-out PSNR every n steps (0: only at the end)
  int checkpoint_every = 500;  // 0: only at the end
  int max_eval_views = 8;      // test views rendered for the periodic evaluation
  unsigned seed = 0;
  int stop_after = 0;             // > 0: checkpoint and return at this step (train in slices)
  bool random_background = true;  // for RGBA images; white at evaluation
  // The hash table by SparseAdam (tiny-cuda-nn's: untouched entries skipped, one fused pass)
  // instead of torch Adam (nerfacc's, as DReg-NeRF trains). Off in both presets: it trained a
  // worse block and saves a small share of an iteration
  // (docs/notes/2026-11-22-nerf-and-classical-defaults.md). A resumed run keeps its checkpoint's
  // optimizer.
  bool sparse_table_adam = false;
  FieldOptions field;
  OccupancyGridOptions grid;
  MarchOptions march;
  // Where training runs (`--device`): the field (hash table and MLPs), the training pixels and
  // their rays, the occupancy grid, marching, compositing and the loss all live there. Random
  // draws (batches, background colours, marching offsets, grid cells) are made on the CPU from the
  // run's generator and copied, so every device trains on the same batches and samples. The
  // sparse table Adam is a CPU kernel: with it the device must be the CPU.
  torch::Device device = torch::kCPU;

  // Presets. "default": 16 levels x 2, 2^19 table, 128^3 grid, step 3 sqrt(3)/1024 of a 3-wide
  // box, 2^18 samples, 10k iterations. "fast": 2^17 table, 64^3 grid, 4x the step, 2^16 samples,
  // 2000 iterations (measured in bench/).
  static NerfTrainOptions Preset(const std::string& name);
  void Check() const;  // throws InputError naming the option
  Json ToJson() const;
};

struct NerfTrainResult {
  double psnr_test = 0;  // mean over the held-out views (white background)
  double seconds = 0;
  int iterations = 0;
  double final_loss = 0;
};

// Trains on `dataset` (train split), evaluates on its test split, writes `checkpoint_path` (and
// `checkpoint_path`.log.jsonl with the curves). With resume, continues from the checkpoint.
// Throws InputError on bad data; std::runtime_error("... NaN at step N ...") when training
// diverges, leaving the last good checkpoint untouched.
NerfTrainResult TrainNerfBlock(const Dataset& dataset, const NerfTrainOptions& options,
                               const std::string& checkpoint_path, bool resume);

// Mean PSNR / SSIM of the block's renders of the dataset's test views (white background).
struct NerfEvalResult {
  double psnr = 0, ssim = 0;
  int views = 0;
};
NerfEvalResult EvaluateNerfBlock(NerfBlock& block, const Dataset& dataset, int max_views = 0);

}  // namespace nerfreg
