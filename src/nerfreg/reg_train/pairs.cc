#include "nerfreg/reg_train/pairs.h"

#include "nerfreg/data/ground_truth.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

Json PairRecord::ToJson() const {
  return {{"name", name},
          {"object", object},
          {"kind", kind},
          {"split", split},
          {"source", source},
          {"target", target},
          {"target_from_source", MatrixToJson(target_from_source)},
          {"overlap", overlap},
          {"source_block", source_block},
          {"target_block", target_block},
          {"blocks", blocks}};
}

PairRecord PairRecord::FromJson(const JsonField& j) {
  PairRecord p;
  p.name = j["name"].String();
  p.object = j.StringOr("object", p.name);
  p.kind = j.StringOr("kind", "mesh");
  p.split = j.StringOr("split", "train");
  p.source = j["source"].String();
  p.target = j["target"].String();
  p.target_from_source = j["target_from_source"].Matrix(4, 4);
  p.overlap = j.DoubleOr("overlap", 0);
  p.source_block = j.IntOr("source_block", 0);
  p.target_block = j.IntOr("target_block", 1);
  p.blocks = j.IntOr("blocks", 2);
  return p;
}

std::vector<PairRecord> ReadPairs(const std::string& path) {
  const Json j = ReadJsonFile(path);
  const JsonField f(j, path);
  std::vector<PairRecord> out;
  const JsonField pairs = f["pairs"];
  for (size_t i = 0; i < pairs.ArraySize(); ++i) {
    PairRecord p = PairRecord::FromJson(pairs[i]);
    p.source = JoinPaths(ParentDir(path), p.source);
    p.target = JoinPaths(ParentDir(path), p.target);
    out.push_back(p);
  }
  return out;
}

void BlockPairOptions::Check() const {
  if (blocks < 2 || blocks > 8) ThrowInputError("--blocks", "", "2..8");
  if (split != "train" && split != "val" && split != "test") ThrowInputError("--split", "", "train, val or test");
  if (!(min_overlap >= 0 && min_overlap <= 1)) ThrowInputError("--min-overlap", "", "in [0, 1]");
  nerf.Check();
  grid.Check();
}

std::vector<PairRecord> TrainBlockPairs(const std::string& out_dir, const std::string& rel, const std::string& object,
                                        const BlockPairOptions& o, Json* cost) {
  o.Check();
  const std::string dir = JoinPaths(out_dir, rel);
  const std::string data = JoinPaths(dir, "data");
  const GroundTruthFile truth(JoinPaths(data, "ground_truth.json"));
  std::vector<RegGrid> grids;
  std::vector<Sim3d> from_world;
  Json psnr = Json::array();
  double train_seconds = 0, grid_seconds = 0;
  for (int k = 0; k < o.blocks; ++k) {
    const std::string block_dir = JoinPaths(data, "block_" + std::to_string(k));
    const std::string ckpt = JoinPaths(dir, "block_" + std::to_string(k) + ".ckpt");
    const std::string grid_path = JoinPaths(dir, "block_" + std::to_string(k) + ".grid");
    from_world.push_back(truth.BlockFromWorld(k));
    if (!FileExists(grid_path)) {
      Timer t;
      const Dataset d = ReadTransformsJson(JoinPaths(block_dir, "transforms.json"));
      bool resume = false;
      if (FileExists(ckpt)) resume = LoadNerfBlock(ckpt).step < o.nerf.iterations;
      NerfTrainOptions no = o.nerf;
      no.seed = o.seed + k;
      const NerfTrainResult tr =
          (FileExists(ckpt) && !resume) ? NerfTrainResult{} : TrainNerfBlock(d, no, ckpt, resume);
      train_seconds += t.Seconds();
      psnr.push_back(tr.psnr_test);
      Timer te;
      NerfBlock block = LoadNerfBlock(ckpt, nullptr, o.nerf.device);
      GridExtractionOptions go = o.grid;
      go.seed = o.seed + k;
      SaveRegGrid(ExtractRegGrid(block, go), grid_path);
      grid_seconds += te.Seconds();
    }
    grids.push_back(LoadRegGrid(grid_path));
  }
  if (cost != nullptr) {
    (*cost)["train_seconds"] = train_seconds;
    (*cost)["grid_seconds"] = grid_seconds;
    (*cost)["psnr_test"] = psnr;
  }
  std::vector<PairRecord> out;
  Json overlaps = Json::array();
  for (int a = 0; a < o.blocks; ++a) {
    for (int b = a + 1; b < o.blocks; ++b) {
      PairRecord r;
      r.name = object + "/nerf_" + std::to_string(a) + "_" + std::to_string(b);
      r.object = object;
      r.kind = "nerf";
      r.split = o.split;
      r.source = rel + "/block_" + std::to_string(a) + ".grid";
      r.target = rel + "/block_" + std::to_string(b) + ".grid";
      r.target_from_source = (from_world[b] * from_world[a].Inverse()).ToMatrix();
      r.overlap = GridOverlap(grids[a], grids[b], r.target_from_source);
      r.source_block = a;
      r.target_block = b;
      r.blocks = o.blocks;
      overlaps.push_back(r.overlap);
      if (r.overlap >= o.min_overlap) out.push_back(r);
    }
  }
  if (cost != nullptr) (*cost)["overlaps"] = overlaps;  // every pair's, also those left out
  return out;
}

}  // namespace nerfreg
