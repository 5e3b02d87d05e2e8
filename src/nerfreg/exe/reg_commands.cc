// Commands of the registration layer: reg register | reg eval (reg register-many: reg_many_command.cc).
#include <fmt/format.h>

#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/exe/reg_flags.h"
#include "nerfreg/pipeline/register_blocks.h"
#include "nerfreg/pipeline/register_many_blocks.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg/registration_success.h"
#include "nerfreg/registration/registration_options.h"
#include "nerfreg/registration/scale_normalization.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/util/torch_device.h"

using namespace nerfreg;

// ICP on the grids: its points and the half-turn check (GridRegistrationOptions); the points as
// typed, parsed by IcpPointsFromName after CLI11 has checked the name.
void AddIcpOptions(CLI::App& app, std::string* icp_points, bool* no_flips, double* icp_distance) {
  app.add_option("--icp-points", *icp_points,
                 "Grids: the points ICP aligns, occupied (every voxel over the density threshold; default) or mask "
                 "(the surface mask the network sees)")
      ->check(CLI::IsMember({"occupied", "mask"}));
  app.add_flag("--no-flips", *no_flips,
               "Grids: ICP from the pose alone, not also from its 9 half-turns (by default the one whose voxels agree "
               "best in place and colour is kept)");
  app.add_option("--icp-distance", *icp_distance,
                 "Grids: ICP's correspondence distance in ICP voxels (max(--voxel, 1.1 grid cells); default " +
                     fmt::format("{:g}", kDefaultIcpDistance) + ")")
      ->check(CLI::PositiveNumber);
}

// FPFH + RANSAC's time grows quickly with the points of a large block; the cap keeps it a few
// seconds without changing a pose on the held-out pairs
// (docs/notes/2026-11-23-grids-icp-half-turn.md, "The --max-points cap").
void AddMaxPointsOption(CLI::App& app, int* max_points) {
  app.add_option("--max-points", *max_points,
                 "ransac / fgr on the occupied points: above this many points after downsampling, the features and "
                 "the global search use a coarser voxel (ICP stays at --voxel); 0: no cap (default 5000)")
      ->check(CLI::NonNegativeNumber);
}

// The shipped weights: NERFREG_WEIGHTS overrides; else models/dreg_cpu.pt of the source tree.
std::string DefaultDregWeights() {
  if (const char* env = std::getenv("NERFREG_WEIGHTS")) return env;
  return std::string(NERFREG_MODELS_DIR) + "/dreg_cpu.pt";
}

// auto (dreg, falling back to FPFH + RANSAC when its confidence is low) when weights are there,
// else FPFH + RANSAC.
std::string DefaultRegistrationMethod() { return FileExists(DefaultDregWeights()) ? "auto" : "ransac"; }

namespace {

// A nerfstudio run's dataparser_transforms.json (file_from_capture), inverted; none for "".
std::optional<Sim3d> CaptureFromFile(const std::string& dataparser) {
  if (dataparser.empty()) return std::nullopt;
  const Sim3d file_from_capture = ReadDataparserTransforms(dataparser);
  CheckScaleInRange(file_from_capture.scale, dataparser, "scale");
  return file_from_capture.Inverse();
}

// reg register's own flags: the inputs, the output, and the pair's options.
struct RegisterFlags {
  std::string source, target, out;
  std::string source_dataparser, target_dataparser;
  PairRegistrationFlags pair;
};

void AddRegisterFlags(CLI::App& app, RegisterFlags* f) {
  app.add_option(
         "source", f->source,
         "Source: a NeRF block checkpoint, an instant-ngp snapshot (.ingp, .msgpack) or a 3D Gaussian splat PLY")
      ->required();
  app.add_option(
         "target", f->target,
         "Target: a NeRF block checkpoint, an instant-ngp snapshot (.ingp, .msgpack) or a 3D Gaussian splat PLY")
      ->required();
  app.add_option("--source-dataparser", f->source_dataparser,
                 "The source is in nerfstudio's trained frame (a splat from ns-export gaussian-splat): its run's "
                 "dataparser_transforms.json, so that it registers, and T is written, in the units of its capture's "
                 "cameras");
  app.add_option("--target-dataparser", f->target_dataparser, "The same for the target");
  app.add_option("--out", f->out, "Output JSON")->required();
  AddPairRegistrationFlags(app, &f->pair);
}

}  // namespace

void nerfreg::AddPairRegistrationFlags(CLI::App& app, PairRegistrationFlags* f) {
  BlockRegistrationOptions& o = f->options;
  o.weights = DefaultDregWeights();
  f->method = DefaultRegistrationMethod();
  AddDeviceOption(app, &f->device);
  app.add_option("--method", f->method,
                 "auto (default with weights: dreg and ransac, each refined, the one whose fields agree best on common "
                 "samples kept; without --refine field: dreg, then ransac when dreg's confidence < --min-confidence), "
                 "dreg, ransac or fgr")
      ->check(CLI::IsMember({"auto", "ransac", "fgr", "dreg"}));
  app.add_option("--scale", f->scale,
                 "free (default: each input normalised by its own occupied extent, the scale between them estimated; "
                 "the result is a similarity) or fixed (the inputs share a unit: rigid)")
      ->check(CLI::IsMember({"free", "fixed"}));
  app.add_option("--min-confidence", o.min_confidence,
                 "auto without --refine field: dreg answers below this confidence fall back to ransac (0.3)");
  app.add_option("--refine", f->refine,
                 "none, icp (point-to-plane ICP; on the grids see --icp-points, --no-flips, then again on the blocks' "
                 "occupied points, see --no-block-icp) or field (ICP, then the two density fields aligned: finer than "
                 "the grid)")
      ->check(CLI::IsMember({"none", "icp", "field"}));
  app.add_option("--field-iterations", o.field.iterations,
                 "field: Levenberg-Marquardt iterations at most (default 30)");
  app.add_option("--field-occupancy-scale", o.field.occupancy_scale,
                 "field: occupancy = 1 - exp(-scale * density) (default 0.05)");
  app.add_option("--field-samples", o.field.max_samples, "field: samples per block at most (default 6000)");
  app.add_option("--weights", o.weights, "DReg-NeRF weights (method dreg; default: the shipped models/dreg_cpu.pt)");
  app.add_option("--grid-resolution", o.grid.resolution,
                 "dreg: grid voxels per side (default 32, as the shipped weights were trained)");
  app.add_option("--config", o.config, "dreg: require weights of this network config (cpu or paper)")
      ->check(CLI::IsMember({"cpu", "paper"}));
  app.add_option("--min-density", o.min_density, "Density above which a cell's point is used (default 5)");
  app.add_option("--voxel", o.voxel, "Downsampling voxel, scene units (default 0.05)");
  AddMaxPointsOption(app, &o.max_points);
  AddIcpOptions(app, &f->icp_points, &f->no_flips, &o.icp_distance);
  app.add_option("--seed", o.seed, "Random seed");
  app.add_option("--dreg-solver", f->dreg_solver,
                 "dreg: pose from the network's correspondences by procrustes (default: the paper's weighted Kabsch "
                 "over all of them) or ransac (RANSAC over them, then Kabsch on its inliers)")
      ->check(CLI::IsMember({"ransac", "procrustes"}));
  app.add_option("--dreg-passes", o.dreg_passes,
                 "dreg: network passes; each after the first re-runs the network on the source moved by the pose so "
                 "far (default 1, as the paper)")
      ->check(CLI::Range(1, 10));
  app.add_option("--splat-density-scale", o.splats.density_scale,
                 "Splat inputs: density per unit of summed opacity (default 20; docs/registration.md)");
  app.add_option("--splat-blur", o.splats.blur,
                 "Splat inputs: standard deviation added to every splat, scene units (default 0.01)");
  app.add_flag("--no-block-icp", f->no_block_icp,
               "Grids (dreg, auto): ICP on the grids only, not again on the blocks' occupied points (by default it "
               "runs after ICP on the grids, before --refine field)");
  app.add_flag("--no-turn-check", f->no_turn_check,
               "--refine field: do not try the kept pose turned about the source's axes (by default a turn that "
               "agrees better replaces it, and one that agrees nearly as well makes the result untrusted)");
  app.add_flag("--no-reverse", f->no_reverse,
               "Do not register the pair the other way (target onto source) where the result is untrusted (by "
               "default that one, inverted, is kept when it is registered)");
}

BlockRegistrationOptions nerfreg::ParsePairRegistrationFlags(const PairRegistrationFlags& f) {
  BlockRegistrationOptions o = f.options;
  o.device = ParseDevice(f.device);
  o.method = RegistrationMethodFromName(f.method);
  o.refine = RegistrationRefinementFromName(f.refine);
  o.dreg_solver = DregSolverFromName(f.dreg_solver);
  o.icp_points = IcpPointsFromName(f.icp_points);
  o.scale = ScaleModeFromName(f.scale);
  o.flips = !f.no_flips;
  o.block_icp = !f.no_block_icp;
  o.check_turns = !f.no_turn_check;
  o.reverse_untrusted = !f.no_reverse;
  o.Check();
  return o;
}

int RunRegRegister(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Register two NeRF blocks (or 3D Gaussian splat PLYs, or one of each) from their fields alone: "
                  "target_from_source maps points of the source's frame into the target's. Methods: ransac (FPFH + "
                  "RANSAC), fgr (FPFH + fast global "
                  "registration), dreg (the learned DReg-NeRF network; needs trained weights), auto (dreg and "
                  "ransac, the best on the fields kept). Refinement: icp (on the grids, then on the blocks' occupied "
                  "points), then by default field (the two density fields aligned). Writes T.json (with the options "
                  "used) and before/after overlay pictures beside it.",
                  "nerfreg reg register runs/block_0.ckpt runs/block_1.ckpt --out runs/target_from_source.json");
  RegisterFlags f;
  AddRegisterFlags(app, &f);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(f.out, common.force,
                      {f.source, f.target, f.pair.options.weights, f.source_dataparser, f.target_dataparser});
  const BlockRegistrationOptions o = ParsePairRegistrationFlags(f.pair);
  Timer timer;
  const std::optional<Sim3d> source_from_file = CaptureFromFile(f.source_dataparser),
                             target_from_file = CaptureFromFile(f.target_dataparser);
  const auto source = LoadRegistrationInput(f.source, o.splats, o.device, source_from_file);
  const auto target = LoadRegistrationInput(f.target, o.splats, o.device, target_from_file);
  std::unique_ptr<DregNet> net;
  if (o.UsesNetwork()) net = std::make_unique<DregNet>(LoadCheckedDregNet(o));
  BlockRegistrationResult r = RegisterBlocks(*source, *target, o, net.get());
  r.seconds = timer.Seconds();  // T.json's seconds: the whole command, loading included
  Json json = r.ToJson();
  json["source"] = f.source;  // the report finds the blocks' points by these names
  json["target"] = f.target;
  // Where an input was moved on load: T maps the source's capture frame into the target's.
  for (const auto& [key, path, capture_from_file] :
       {std::tuple{"source_frame", &f.source_dataparser, &source_from_file},
        std::tuple{"target_frame", &f.target_dataparser, &target_from_file}}) {
    if (*capture_from_file) {
      json[key] = {{"dataparser", *path}, {"capture_from_file", MatrixToJson((*capture_from_file)->ToMatrix())}};
    }
  }
  WriteJsonFile(f.out, json);
  WriteRegistrationOverlays(f.out, r);
  // A person reads the summary; --json (with the logs as JSON lines) prints the record itself.
  std::printf("%s", common.json ? (json.dump() + "\n").c_str() : RegistrationSummary(r, f.out).c_str());
  if (r.status == "untrusted") {
    std::fprintf(stderr, "untrusted: %s (%s written with \"status\": \"untrusted\")\n", r.status_reason.c_str(),
                 f.out.c_str());
    return kExitUntrusted;
  }
  return 0;
}
