// Fuzzes the loaders of our torch-archive files: NeRF block checkpoints (LoadNerfBlock),
// registration grids (LoadRegGrid), DReg-NeRF weights (LoadDregWeights) and generalizable-NeRF
// checkpoints (LoadGeneralizableNerf) and DBARF weights (LoadDbarfWeights), all behind
// LoadArchiveMeta. Built only in the LibTorch
// fuzz build (scripts/fuzz.sh, build-fuzz-torch/).
//
// Input: byte 0 picks the loader (bits 0-1, and bit 3 for the fifth: (b & 3) | (b & 8) >> 1,
// modulo 5) and the mode (bit 2); the rest is
//   raw mode:  the whole file. Torch archives are zip files whose entries carry CRC-32s that the
//              reader checks, so random mutations mostly exercise the zip container, the pickle
//              header and LoadArchiveMeta's error paths;
//   meta mode: the "meta" JSON alone, put into an otherwise valid archive of that kind (the real
//              tensors of a tiny object, written here the way each Save* writes them). This is
//              what reaches our own validation of the stored options, shapes and sizes: a
//              corrupt size there must be an InputError, never a huge allocation or a crash.
// A loader may only ever throw InputError; any other exception escapes and is a finding, as are
// crashes, sanitizer reports and allocations over libFuzzer's -rss_limit_mb / -malloc_limit_mb.
//
// NERFREG_FUZZ_WRITE_SEEDS=DIR writes the seed corpus (fuzz/corpus/torch_archive/) instead:
// tiny archives from the project's own writers (raw mode) and their meta JSON (meta mode).
#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/generalizable_nerf.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/torch_archive.h"

namespace nerfreg {
namespace {

// The smallest valid object of each kind; sizes chosen so a seed archive is a few KB.
struct TinyObjects {
  NerfBlock block;
  RegGrid grid;
  DregModelOptions dreg_options;
  DregNet dreg{nullptr};
  GeneralizableNerf gnerf{TinyGeneralizableOptions()};
  DbarfModel dbarf{TinyDbarfOptions()};

  static DbarfOptions TinyDbarfOptions() {
    DbarfOptions o;
    o.nerf = TinyGeneralizableOptions();
    o.pose = PoseDepthNetOptions::Cpu();
    o.pose.encoder_widths = {4, 4, 4};
    o.pose.fuse_channels = 4;
    o.pose.feature_channels = 4;
    o.pose.hidden_channels = 4;
    o.pose.context_channels = 2;
    o.pose.motion_channels = 8;
    o.pose.state_channels = 2;
    o.pose.head_channels = 4;
    o.pose.mask_channels = 4;
    o.pose.outer_iterations = 1;
    o.pose.inner_iterations = 1;
    return o;
  }

  static GeneralizableNerfOptions TinyGeneralizableOptions() {
    GeneralizableNerfOptions o = GeneralizableNerfOptions::Cpu();
    o.features.stem_channels = 4;
    o.features.layer_channels = {4, 4, 4};
    o.features.layer_blocks = {1, 1, 1};
    o.features.out_channels = 4;
    o.features.nerf_channels = 4;
    o.ibrnet.feature_channels = 4;
    o.ibrnet.attention_heads = 1;
    return o;
  }

  TinyObjects() {
    FieldOptions fo;
    fo.encoding.levels = 2;
    fo.encoding.log2_table_size = 4;
    fo.hidden_dim = 8;
    OccupancyGridOptions go;
    go.resolution = 4;
    block = NerfBlock::Create(fo, go, MarchOptions{}, 1);

    const int d = 4;
    grid.aabb_min = Eigen::Vector3d::Constant(-1);
    grid.aabb_max = Eigen::Vector3d::Constant(1);
    grid.rgba = torch::rand({4, d, d, d});
    grid.xyz = torch::rand({d, d, d, 3}) * 2 - 1;
    grid.surface = torch::rand({d, d, d});
    grid.mask = grid.surface > 0.5;

    dreg_options.backbone.stem_channels = 2;
    dreg_options.backbone.stage_widths = {2};
    dreg_options.backbone.stage_blocks = {1};
    dreg_options.backbone.fpn_channels = 6;
    dreg_options.d_model = 6;
    dreg_options.heads = 1;
    dreg_options.layers = 1;
    dreg_options.ffn = 4;
    dreg_options.name = "fuzz";
    dreg = DregNet(dreg_options);
  }
};

TinyObjects& Tiny() {
  static TinyObjects* tiny = new TinyObjects();
  return *tiny;
}

enum Kind { kNerfBlock = 0, kRegGrid = 1, kDregWeights = 2, kGeneralizableNerf = 3, kDbarfWeights = 4 };
constexpr int kNumKinds = 5;

// The archive of `kind` with `meta` as its meta entry, laid out as the kind's Save* lays it out
// (nerf_block.cc, reg_grid.cc, dreg_model.cc, generalizable_nerf.cc).
void WriteWithMeta(Kind kind, const std::string& meta, const std::string& path) {
  TinyObjects& t = Tiny();
  torch::serialize::OutputArchive archive;
  archive.write("meta", StringTensor(meta));
  if (kind == kNerfBlock) {
    torch::serialize::OutputArchive field;
    t.block.field->save(field);
    archive.write("field", field);
    archive.write("grid_density", t.block.grid->density());
    archive.write("grid_occupied", t.block.grid->occupied().to(torch::kUInt8));
  } else if (kind == kRegGrid) {
    archive.write("rgba", t.grid.rgba);
    archive.write("xyz", t.grid.xyz);
    archive.write("surface", t.grid.surface);
    archive.write("mask", t.grid.mask.to(torch::kUInt8));
  } else if (kind == kDregWeights) {
    torch::serialize::OutputArchive model;
    t.dreg->save(model);
    archive.write("model", model);
  } else if (kind == kDbarfWeights) {
    torch::serialize::OutputArchive features, ibrnet, pose;
    t.dbarf.nerf.feature_net->save(features);
    t.dbarf.nerf.ibrnet->save(ibrnet);
    t.dbarf.pose_net->save(pose);
    archive.write("feature_net", features);
    archive.write("ibrnet", ibrnet);
    archive.write("pose_net", pose);
  } else {
    torch::serialize::OutputArchive features, ibrnet;
    t.gnerf.feature_net->save(features);
    t.gnerf.ibrnet->save(ibrnet);
    archive.write("feature_net", features);
    archive.write("ibrnet", ibrnet);
  }
  archive.save_to(path);
}

void Load(Kind kind, const std::string& path) {
  switch (kind) {
    case kNerfBlock:
      LoadNerfBlock(path);
      break;
    case kRegGrid:
      LoadRegGrid(path);
      break;
    case kDregWeights: {
      DregModelOptions options;
      LoadDregWeights(path, &options);
      break;
    }
    case kGeneralizableNerf:
      LoadGeneralizableNerf(path, nullptr);
      break;
    case kDbarfWeights:
      LoadDbarfWeights(path, nullptr);
      break;
  }
}

void WriteSeeds(const std::string& dir) {
  TinyObjects& t = Tiny();
  CreateDirectories(dir);
  const std::string tmp = JoinPaths(dir, "tmp.pt");
  const char* names[] = {"nerf_block", "reg_grid", "dreg_weights", "generalizable_nerf", "dbarf_weights"};
  for (int k = 0; k < kNumKinds; ++k) {
    if (k == kNerfBlock) SaveNerfBlock(t.block, tmp);
    if (k == kRegGrid) SaveRegGrid(t.grid, tmp);
    if (k == kDregWeights) SaveDregWeights(t.dreg, t.dreg_options, tmp);
    if (k == kGeneralizableNerf) SaveGeneralizableNerf(t.gnerf, tmp);
    if (k == kDbarfWeights) SaveDbarfWeights(t.dbarf, tmp);
    Load(static_cast<Kind>(k), tmp);  // every seed must load
    const std::string bytes = ReadFileToString(tmp);
    const auto selector = [](int kind, int mode) { return char((kind & 3) | ((kind & 4) << 1) | mode); };
    WriteFileAtomic(JoinPaths(dir, std::string("raw_") + names[k]), std::string(1, selector(k, 0)) + bytes);
    torch::serialize::InputArchive archive;
    archive.load_from(tmp);
    torch::Tensor meta;
    archive.read("meta", meta);
    WriteFileAtomic(JoinPaths(dir, std::string("meta_") + names[k]),
                    std::string(1, selector(k, 4)) + TensorString(meta));
  }
  std::filesystem::remove(tmp);
}

}  // namespace
}  // namespace nerfreg

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  torch::set_num_threads(1);
  torch::manual_seed(1);
  nerfreg::InitLogging(nerfreg::LogOptions{});
  spdlog::set_level(spdlog::level::off);  // option checks log why they refuse: noise at 1000s of runs/s
  nerfreg::Tiny();
  if (const char* dir = std::getenv("NERFREG_FUZZ_WRITE_SEEDS")) {
    nerfreg::WriteSeeds(dir);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace nerfreg;
  if (size < 1) return 0;
  const Kind kind = static_cast<Kind>(((data[0] & 3) | ((data[0] & 8) >> 1)) % kNumKinds);
  const bool meta_mode = data[0] & 4;
  std::string path;
  if (meta_mode) {
    path = WriteFuzzInput(data, 0, ".pt");
    WriteWithMeta(kind, std::string(reinterpret_cast<const char*>(data + 1), size - 1), path);
  } else {
    path = WriteFuzzInput(data + 1, size - 1, ".pt");
  }
  try {
    Load(kind, path);
  } catch (const InputError&) {
  }
  return 0;
}
