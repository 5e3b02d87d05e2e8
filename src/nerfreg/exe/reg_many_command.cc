// reg register-many: many blocks (or splat captures) into one frame, and what it can write there.
#include <cstdio>
#include <map>
#include <memory>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/exe/reg_flags.h"
#include "nerfreg/pipeline/register_many_blocks.h"
#include "nerfreg/registration/register_blocks.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"

using namespace nerfreg;

namespace {

// "K=FILE" flags, one per input K (from 0); a malformed one or a K given twice is a named error.
std::map<int, std::string> IndexedPaths(const std::vector<std::string>& flags, const std::string& flag) {
  std::map<int, std::string> out;
  for (const std::string& f : flags) {
    const size_t eq = f.find('=');
    int k = -1;
    try {
      size_t used = 0;
      if (eq != std::string::npos && eq > 0) k = std::stoi(f.substr(0, eq), &used);
      if (used != eq) k = -1;
    } catch (const std::exception&) {
      k = -1;
    }
    if (k < 0 || eq + 1 >= f.size()) ThrowInputError(flag, "", "K=FILE with K an input's index from 0, got " + f);
    if (!out.emplace(k, f.substr(eq + 1)).second) ThrowInputError(flag, "", "one file per input, got two for " + f);
  }
  return out;
}

}  // namespace

int RunRegRegisterMany(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Register many NeRF blocks (or splat captures) into one frame (block 0's): every pair is registered as "
      "reg register registers it (the same flags), the pairs it trusts become edges of a pose graph, which is "
      "solved with a robust loss from a cycle-consistent spanning tree; with --scale free (default) every "
      "block's scale too (a Sim(3) graph). Writes {status, world_from_block: [4x4...], scale: [...], edges: "
      "[...]}; exits with 5 when an input is linked to block 0 by no trusted registration (it is left out of "
      "the merged outputs).",
      "nerfreg reg register-many runs/b0.ckpt runs/b1.ckpt runs/b2.ckpt --out runs/poses.json");
  std::vector<std::string> paths;
  std::string out;
  PairRegistrationFlags pair;
  app.add_option("blocks", paths,
                 "Block checkpoints, instant-ngp snapshots or splat PLYs (the first defines the world frame)")
      ->required()
      ->expected(2, 1000);
  app.add_option("--out", out, "Output JSON")->required();
  std::string merged, merged_cameras;
  app.add_option("--merged-splats", merged,
                 "Also write the splat inputs moved into the world frame, merged, to this PLY");
  app.add_option("--merged-cameras", merged_cameras,
                 "Also write every block's cameras moved into the world frame, in one transforms.json");
  std::vector<std::string> dataparsers, cameras;
  app.add_option("--dataparser", dataparsers,
                 "K=FILE: input K (from 0) is in nerfstudio's trained frame (a splat from ns-export gaussian-splat); "
                 "FILE is its run's dataparser_transforms.json, so that it registers, and is written, in the units "
                 "of its capture's cameras (repeatable)");
  app.add_option("--cameras", cameras,
                 "K=FILE: the cameras of splat input K for --merged-cameras, a transforms.json, COLMAP model or LLFF "
                 "scene in its capture's frame (repeatable)");
  AddPairRegistrationFlags(app, &pair);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  const std::map<int, std::string> dataparser_of = IndexedPaths(dataparsers, "--dataparser"),
                                   cameras_of = IndexedPaths(cameras, "--cameras");
  std::vector<std::string> inputs = paths;
  inputs.push_back(pair.options.weights);
  for (const auto& m : {dataparser_of, cameras_of})
    for (const auto& [k, p] : m) inputs.push_back(p);
  CheckCanWriteOutput(out, common.force, inputs);
  if (!merged.empty()) CheckCanWriteOutput(merged, common.force, inputs);
  if (!merged_cameras.empty()) CheckCanWriteOutput(merged_cameras, common.force, inputs);
  ManyBlockRegistrationOptions o;
  o.pair = ParsePairRegistrationFlags(pair);
  for (const auto& [k, p] : dataparser_of) o.capture_from_file[k] = ReadDataparserTransforms(p).Inverse();
  o.Check();
  std::unique_ptr<DregNet> net;
  if (o.pair.UsesNetwork()) net = std::make_unique<DregNet>(LoadCheckedDregNet(o.pair));
  const ManyBlockRegistrationResult r = RegisterManyBlocks(paths, o, net.get());
  WriteJsonFile(out, r.json);
  if (!merged.empty()) WriteSplatPly(MergeSplatsInWorld(paths, r), merged);
  if (!merged_cameras.empty())
    LOG_INFO("{} cameras -> {}", WriteMergedCameras(paths, r, merged_cameras, cameras_of), merged_cameras);
  LOG_INFO("{} blocks, {} of {} pairs used, {:.1f} s", paths.size(), r.used_edges, r.pairs,
           r.json["seconds"].get<double>());
  if (r.unconnected > 0) {
    std::fprintf(stderr, "untrusted: %s (%s written with \"status\": \"untrusted\")\n",
                 r.json["status_reason"].get<std::string>().c_str(), out.c_str());
    return kExitUntrusted;
  }
  return 0;
}
