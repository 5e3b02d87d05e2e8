// The learned core's registration commands: reg extract | reg train | reg average. They need only
// the nerf, reg and reg_train layers (LibTorch), so the learned-core build (a GPU machine's, docs/gpu.md)
// has them too.
#include <thread>

#include "nerfreg/dist/dist.h"
#include "nerfreg/dist/launch.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/reg_train/dreg_trainer.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

// Shared with reg make-data, whose pairs extract grids the same way.
void AddGridOptions(CLI::App& app, GridExtractionOptions* g) {
  app.add_option("--grid-resolution", g->resolution,
                 "Voxels per side of the grid (default 32, the shipped model's; the paper 128)");
  app.add_option("--grid-side", g->side, "Side of the grid's cube, block units (default 3.6)");
  app.add_option("--min-density", g->min_density, "Density mask threshold (default 0.7, the paper's)");
  app.add_option("--variant", g->variant, "surface (density AND surface field) or df (density only)")
      ->check(CLI::IsMember({"surface", "df"}));
  app.add_option("--surface-cameras", g->surface.max_cameras,
                 "Training cameras the surface field marches from (default 16)");
  app.add_option("--surface-mode", g->surface.mode,
                 "Surface field per ray: max_weight (the paper's max alpha*T), opacity (1 - T at the point) or window "
                 "(the ray's weight within --surface-window of the point)")
      ->check(CLI::IsMember({"max_weight", "opacity", "window"}));
  app.add_option("--surface-window", g->surface.window,
                 "Mode window: the stretch around the point, block units (default one cell)");
  app.add_option("--samples-per-voxel", g->samples_per_voxel,
                 "Jittered density samples per voxel, the densest kept (default 8; the paper 1)");
}

int RunRegExtract(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Extract the voxel grid DReg-NeRF registers from a trained block (spec dreg-nerf.md 3): jittered "
                  "points, density mask, surface field, view-averaged colour and alpha. Writes a .grid file.",
                  "nerfreg reg extract runs/block_0.ckpt --out runs/block_0.grid");
  std::string block_path, out, device = "cpu";
  AddDeviceOption(app, &device);
  GridExtractionOptions g;
  app.add_option("block", block_path, "Block checkpoint (nerf train)")->required();
  app.add_option("--out", out, "Output grid file")->required();
  AddGridOptions(app, &g);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const torch::Device dev = ParseDevice(device);
  CheckCanWriteOutput(out, common.force, {block_path});
  Timer timer;
  NerfBlock block = LoadNerfBlock(block_path, nullptr, dev);
  const RegGrid grid = ExtractRegGrid(block, g);
  const std::int64_t masked = grid.mask.sum().item<std::int64_t>();
  if (masked < 100)
    LOG_WARN("{}: only {} voxels in the mask: is the block trained / its occupancy grid empty?", block_path, masked);
  SaveRegGrid(grid, out);
  std::printf("%s\n", Json({{"grid", out}, {"masked_voxels", masked}, {"seconds", timer.Seconds()}}).dump().c_str());
  return 0;
}
int RunRegTrain(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Train the DReg-NeRF network on pairs made by reg make-data (split train; split val validates). "
                  "Writes OUT (the weights, small), OUT.train (the state --resume continues), OUT.log.jsonl and "
                  "OUT.json (summary).",
                  "nerfreg reg train data/reg/pairs.json --out runs/dreg_cpu.pt --iters 20000");
  std::vector<std::string> data;
  std::string out;
  DregTrainOptions o;
  DistOptions dist;
  bool resume = false;
  std::string device = "cpu";
  AddDeviceOption(app, &device);
  app.add_option("data", data, "pairs.json files")->required()->expected(1, 100);
  app.add_option("--out", out, "Output weights")->required();
  app.add_option("--config", o.config, "Network size: cpu or paper")->check(CLI::IsMember({"cpu", "paper"}));
  app.add_option("--iters", o.iterations, "Iterations (default 20000)");
  app.add_option("--batch", o.batch,
                 "Pairs per step over all processes; their gradients averaged (default: 1 per process)");
  app.add_option("--lr", o.lr, "AdamW learning rate (default 1e-4)");
  app.add_option("--lr-step", o.lr_step, "StepLR period (default 8000)");
  app.add_option("--val-every", o.val_every, "Validate every n steps (default 500)");
  app.add_option("--checkpoint-every", o.checkpoint_every, "Checkpoint every n steps (default 100)");
  app.add_option("--stop-after", o.stop_after, "Checkpoint and stop at this step (train in slices)");
  app.add_option("--nerf-fraction", o.nerf_fraction, "Chance per step of a real-NeRF pair (default 0: by count)");
  app.add_option("--seed", o.seed, "Random seed");
  app.add_option("--init", o.init_weights,
                 "Start from these weights with a fresh optimizer (fine-tuning; same --config)");
  app.add_option("--move-deg", o.move_deg,
                 "Augmentation: the largest rotation of the rigid move of one grid, deg (default 10 as the paper; "
                 "up to 180: any relative rotation)");
  app.add_option("--move-probability", o.move_probability, "Augmentation: chance of that move per step (default 0.5)");
  app.add_option("--mirror", o.mirror_probability,
                 "Augmentation: chance per step of mirroring both grids (another object; default 0)");
  app.add_option("--recolour", o.colour_probability,
                 "Augmentation: chance per step of permuting and scaling both grids' RGB alike (default 0)");
  app.add_flag("--overlap-labels", o.loss.overlap_labels,
               "Confidence and correspondence labels S * O: the surface field times the other block's seen "
               "surface at the true match (the overlap; ours), not S alone (the paper)");
  app.add_flag("--resume", resume, "Continue from OUT.train");
  AddDistOptions(app, &dist);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  // Under --nproc on GPUs local worker r trains on cuda:r (NCCL); too few GPUs is refused here,
  // before any worker starts.
  o.device = ProcessDevice(ParseDevice(device), dist);
  if (!resume) CheckCanWriteOutput(out, common.force, data);
  if (int rc = LaunchIfAsked(dist, argc, argv); rc >= 0) return rc;
  const auto group = DistGroup::FromEnvironment(dist.timeout_s, o.device);
  const DregTrainResult r = TrainDreg(data, o, out, resume, group.get());
  if (!group->is_main()) return 0;
  std::printf("%s\n", Json({{"weights", out},
                            {"iterations", r.iterations},
                            {"seconds", r.seconds},
                            {"final_loss", r.final_loss},
                            // null, not 0, without validation pairs: 0 deg would read as perfect.
                            {"val_median_rotation_deg", r.val.pairs > 0 ? Json(r.val.median_rotation_deg) : Json()},
                            {"val_success_rate", r.val.pairs > 0 ? Json(r.val.success_rate) : Json()},
                            {"val_pairs", r.val.pairs}})
                          .dump()
                          .c_str());
  return 0;
}

int RunRegAverage(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Average several DReg-NeRF weights files of one architecture into one (a model soup: runs "
      "fine-tuned from the same weights, e.g. with different --seed). Parameters are averaged element-wise.",
      "nerfreg reg average runs/a/dreg_cpu.pt runs/b/dreg_cpu.pt --out runs/soup.pt");
  std::vector<std::string> inputs;
  std::string out;
  app.add_option("weights", inputs, "Weights files (reg train), all of one architecture")
      ->required()
      ->expected(1, 1000);
  app.add_option("--out", out, "Output weights file")->required();
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(out, common.force, inputs);
  DregModelOptions options;
  DregNet net = AverageDregWeights(inputs, &options);
  SaveDregWeights(net, options, out);
  std::printf("%s\n", Json({{"weights", out}, {"averaged", inputs.size()}, {"config", options.name}}).dump().c_str());
  return 0;
}
