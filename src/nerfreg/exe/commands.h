#pragma once
// Every subcommand's entry point. Each layer's commands live in exe/<layer>_commands.cc.
// To add a command: declare it here and add a row to NERFREG_COMMAND_TABLE.

#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace nerfreg {
struct GridExtractionOptions;
// Sets torch's intra-op thread count from the hardware (Debian's LibTorch defaults to 1).
void InitThreads();
}  // namespace nerfreg

// data / render (exe/data_commands.cc)
int RunRender(int argc, char** argv);
int RunConvert(int argc, char** argv);
// NeRF blocks (exe/nerf_commands.cc)
int RunNerfTrain(int argc, char** argv);
int RunNerfRender(int argc, char** argv);
int RunNerfEval(int argc, char** argv);
int RunNerfExport(int argc, char** argv);
int RunNerfImport(int argc, char** argv);
// Registration (exe/reg_commands.cc), its evaluation (exe/reg_eval_command.cc)
int RunRegRegister(int argc, char** argv);
int RunRegEval(int argc, char** argv);
// ICP on the grids (--icp-points, --no-flips, --icp-distance) of reg register and reg eval.
void AddIcpOptions(CLI::App& app, std::string* icp_points, bool* no_flips, double* icp_distance);
// reg register-many (exe/reg_many_command.cc)
int RunRegRegisterMany(int argc, char** argv);
// --max-points of reg register and register-many.
void AddMaxPointsOption(CLI::App& app, int* max_points);
// reg apply (exe/apply_command.cc)
int RunRegApply(int argc, char** argv);
// Grids and the network's training, learned core (exe/reg_train_commands.cc)
int RunRegExtract(int argc, char** argv);
int RunRegTrain(int argc, char** argv);
int RunRegAverage(int argc, char** argv);
// The grid options of reg extract and reg make-data.
void AddGridOptions(CLI::App& app, nerfreg::GridExtractionOptions* g);
// The network's training pairs (exe/reg_data_commands.cc)
int RunRegMakeData(int argc, char** argv);
int RunRegSh3fSplit(int argc, char** argv);
// The shipped DReg-NeRF weights (NERFREG_WEIGHTS overrides) and the default method (dreg when they exist).
std::string DefaultDregWeights();
std::string DefaultRegistrationMethod();
// DBARF (exe/dbarf_commands.cc)
int RunDbarfPoses(int argc, char** argv);
int RunDbarfEvalPoses(int argc, char** argv);
// DBARF training and novel views (exe/dbarf_train_commands.cc), evaluation (exe/dbarf_eval_commands.cc,
// exe/dbarf_eval_net_command.cc)
int RunDbarfPretrain(int argc, char** argv);
int RunDbarfFinetune(int argc, char** argv);
int RunDbarfRender(int argc, char** argv);
int RunDbarfEval(int argc, char** argv);
int RunDbarfEvalNet(int argc, char** argv);
// The shipped DBARF weights (NERFREG_DBARF_WEIGHTS overrides).
std::string DefaultDbarfWeights();
// The shipped pose network trained to pose from the identity, what `dbarf poses` runs
// (NERFREG_DBARF_POSE_WEIGHTS overrides).
std::string DefaultDbarfPoseWeights();
// Reports (exe/report_command.cc)
int RunReport(int argc, char** argv);

// The learned-core build (NERFREG_LEARNED_CORE_ONLY: a GPU machine's, without Embree, Open3D, Ceres or
// OpenCV) has the commands of the layers it builds; the others are NERFREG_EDGE_COMMAND rows.
#if NERFREG_LEARNED_CORE_ONLY
#define NERFREG_EDGE_COMMAND(...)
#else
#define NERFREG_EDGE_COMMAND(...) __VA_ARGS__,
#endif

// clang-format off
#define NERFREG_COMMAND_TABLE \
  NERFREG_EDGE_COMMAND({"render", RunRender, "Render a mesh or procedural object into a dataset (and blocks)"}) \
  NERFREG_EDGE_COMMAND({"convert", RunConvert, "Convert camera files: transforms.json, LLFF, COLMAP"}) \
  {"nerf train", RunNerfTrain, "Train a NeRF block on a posed dataset"}, \
  {"nerf render", RunNerfRender, "Render views of a trained block"}, \
  {"nerf eval", RunNerfEval, "PSNR / SSIM of a block on a dataset's test views"}, \
  {"nerf export", RunNerfExport, "Export a block as a coloured point cloud or mesh (PLY)"}, \
  {"nerf import", RunNerfImport, "Import an instant-ngp snapshot (.msgpack / .ingp) as a NeRF block"}, \
  NERFREG_EDGE_COMMAND({"reg register", RunRegRegister, \
      "Register two NeRF blocks or splat sets from their fields (target_from_source)"}) \
  NERFREG_EDGE_COMMAND({"reg apply", RunRegApply, \
      "Apply T.json's Sim(3) to splats, a PLY, cameras or a block checkpoint"}) \
  NERFREG_EDGE_COMMAND({"reg register-many", RunRegRegisterMany, \
      "Register many blocks into one frame (pairwise + pose graph)"}) \
  {"reg extract", RunRegExtract, "Extract the voxel grid DReg-NeRF registers from a block"}, \
  NERFREG_EDGE_COMMAND({"reg make-data", RunRegMakeData, \
      "Make registration training / evaluation pairs (resumable)"}) \
  NERFREG_EDGE_COMMAND({"reg sh3f-split", RunRegSh3fSplit, \
      "Split the Sweet Home 3D furniture into train / val / test meshes (a file)"}) \
  {"reg train", RunRegTrain, "Train the DReg-NeRF network (resumable)"}, \
  {"reg average", RunRegAverage, "Average weights files of one architecture (a model soup)"}, \
  NERFREG_EDGE_COMMAND({"reg eval", RunRegEval, \
      "Rotation / translation errors of a registration against ground truth"}) \
  NERFREG_EDGE_COMMAND({"dbarf poses", RunDbarfPoses, \
      "Poses of unposed images with known intrinsics (transforms.json + COLMAP model)"}) \
  NERFREG_EDGE_COMMAND({"dbarf eval-poses", RunDbarfEvalPoses, \
      "Rotation / centre errors of estimated cameras after Sim(3) alignment"}) \
  {"dbarf pretrain", RunDbarfPretrain, "Pretrain DBARF on many scenes (resumable)"}, \
  {"dbarf finetune", RunDbarfFinetune, "Finetune DBARF weights on one scene (resumable)"}, \
  {"dbarf render", RunDbarfRender, "Novel views from posed images with the generalizable NeRF"}, \
  NERFREG_EDGE_COMMAND({"dbarf eval", RunDbarfEval, \
      "Pose-free pipeline against ground truth: pose errors, novel-view PSNR / SSIM"}) \
  {"dbarf eval-net", RunDbarfEvalNet, "The pose network's relative poses (from the identity) against ground truth"}, \
  NERFREG_EDGE_COMMAND({"report", RunReport, "Write one self-contained HTML page for a run directory"})
// clang-format on
