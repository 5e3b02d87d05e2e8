#include "nerfreg/reg_data/training_data.h"

#include <cctype>
#include <filesystem>
#include <optional>
#include <set>

#include "nerfreg/render/mesh.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/render/render_dataset.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace fs = std::filesystem;

void MakeDataOptions::Check() const {
  if (meshes.empty() && procedural <= 0) ThrowInputError("reg make-data", "objects", "--meshes or --procedural N > 0");
  bool furniture = false;
  for (const auto& m : meshes) {
    if (m.rfind("sh3f:", 0) == 0) {
      const std::string s = m.substr(5);
      if (s != "train" && s != "val" && s != "test")
        ThrowInputError("--meshes", m, "sh3f:train, sh3f:val or sh3f:test");
      furniture = true;
    } else if (!FileExists(m)) {
      ThrowInputError(m, "", "an existing mesh file");
    }
  }
  if (furniture && !FileExists(sh3f_split_file)) {
    ThrowInputError(sh3f_split_file, "", "an existing split file (reg sh3f-split writes it; --sh3f-split)");
  }
  if (sh3f_limit < 0) ThrowInputError("--sh3f-limit", "", ">= 0");
  if (mesh_pairs < 0 || nerf_objects < 0) ThrowInputError("--mesh-pairs/--nerf-objects", "", ">= 0");
  if (render_only && nerf_objects == 0)
    ThrowInputError("--render-only", "", "--nerf-objects N > 0 (the objects to render)");
  if (blocks < 2 || blocks > 8) ThrowInputError("--blocks", "", "2..8");
  if (split != "train" && split != "val") ThrowInputError("--split", "", "train or val");
  if (image_size < 16) ThrowInputError("--image-size", "", ">= 16");
  nerf.Check();
  grid.Check();
  if (synthetic.resolution != grid.resolution || synthetic.side != grid.side) {
    ThrowInputError("--grid-resolution", "", "the same grid for synthesised and NeRF pairs");
  }
  try {
    synthetic.Check();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("reg make-data: ") + e.what());
  }
}

Json MakeDataOptions::ToJson() const {
  return {{"meshes", meshes},
          {"sh3f_split_file", sh3f_split_file},
          {"sh3f_dir", sh3f_dir},
          {"sh3f_limit", sh3f_limit},
          {"procedural", procedural},
          {"procedural_seed", procedural_seed},
          {"mesh_pairs", mesh_pairs},
          {"nerf_objects", nerf_objects},
          {"render_only", render_only},
          {"blocks", blocks},
          {"split", split},
          {"image_size", image_size},
          {"nerf", nerf.ToJson()},
          {"grid_resolution", grid.resolution},
          {"grid_side", grid.side},
          {"variant", grid.variant},
          {"min_density", grid.min_density},
          {"surface_mode", grid.surface.mode},
          {"surface_window", grid.ResolvedSurface().window},
          {"scale_augment", synthetic.max_relative_scale},
          {"seed", seed}};
}

namespace {

struct ObjectSpec {
  std::string name;
  std::string mesh_path;  // empty: procedural or furniture
  unsigned procedural_seed = 0;
  std::string split;              // of its pairs
  std::optional<Sh3fModel> sh3f;  // a furniture model
};

TriangleMesh LoadObject(const ObjectSpec& o) {
  TriangleMesh m;
  if (o.sh3f) {
    ObjReadReport report;
    m = LoadSh3fModel(*o.sh3f, ObjReadOptions(), &report);
    if (report.warning_count > 0) LOG_DEBUG("{}: {} warnings ({})", o.name, report.warning_count, report.warnings[0]);
  } else {
    m = o.mesh_path.empty() ? ProceduralObject(o.procedural_seed) : LoadMesh(o.mesh_path);
  }
  NormalizeMesh(&m, 2.5f);
  return m;
}

// "sh3f_" and the id with every character other than [A-Za-z0-9_-] as '_' (a folder name).
std::string FurnitureName(const std::string& id) {
  std::string out = "sh3f_";
  for (char c : id) out.push_back(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' ? c : '_');
  return out;
}

// Synthesised pairs of one object.
std::vector<PairRecord> MeshPairs(const ObjectSpec& spec, const TriangleMesh& mesh, const MakeDataOptions& o,
                                  const std::string& out_dir, Json* cost) {
  std::vector<PairRecord> out;
  Json normalizations = Json::array();
  for (int k = 0; k < o.mesh_pairs; ++k) {
    SyntheticPairOptions so = o.synthetic;
    so.blocks = o.blocks;
    // With more than two blocks, walk the pairs of neighbouring blocks.
    so.source_block = k % o.blocks;
    so.target_block = (k + 1) % o.blocks;
    const GridPair p =
        SyntheticGridPair(mesh, so, o.seed * 1000003u + std::hash<std::string>{}(spec.name) % 100000u + k);
    if (o.synthetic.max_relative_scale > 0) normalizations.push_back({p.source_normalization, p.target_normalization});
    if (p.overlap < o.min_overlap) continue;
    PairRecord r;
    r.name = spec.name + "/mesh_" + std::to_string(k);
    r.object = spec.name;
    r.kind = "mesh";
    r.split = spec.split;
    r.source = spec.name + "/mesh_" + std::to_string(k) + "_source.grid";
    r.target = spec.name + "/mesh_" + std::to_string(k) + "_target.grid";
    r.target_from_source = p.target_from_source;
    r.overlap = p.overlap;
    r.source_block = so.source_block;
    r.target_block = so.target_block;
    r.blocks = o.blocks;
    SaveRegGrid(p.source, JoinPaths(out_dir, r.source));
    SaveRegGrid(p.target, JoinPaths(out_dir, r.target));
    out.push_back(r);
  }
  // Each block's normalisation scale (mesh unit to the register path's frame) with --scale-augment.
  if (!normalizations.empty()) (*cost)["normalization_scales"] = normalizations;
  return out;
}

// Real blocks: render, then (unless render_only) train every block, extract grids and pair the
// blocks that overlap (TrainBlockPairs).
std::vector<PairRecord> NerfPairs(const ObjectSpec& spec, const TriangleMesh& mesh, const MakeDataOptions& o,
                                  const std::string& out_dir, Json* cost) {
  const std::string rel = spec.name + "/nerf";
  const std::string data = JoinPaths(out_dir, rel + "/data");
  Timer timer;
  if (!FileExists(JoinPaths(data, "ground_truth.json"))) {
    RenderDatasetOptions r;
    r.blocks = o.blocks;
    r.width = r.height = o.image_size;
    r.seed = o.seed + std::hash<std::string>{}(spec.name) % 100000u;
    r.force = true;
    RenderDataset(mesh, r, data);
  }
  (*cost)["render_seconds"] = timer.Seconds();
  if (o.render_only) return {};
  BlockPairOptions bo;
  bo.blocks = o.blocks;
  bo.min_overlap = o.min_overlap;
  bo.split = spec.split;
  bo.nerf = o.nerf;
  bo.grid = o.grid;
  bo.seed = o.seed;
  return TrainBlockPairs(out_dir, rel, spec.name, bo, cost);
}

std::string UniqueName(const std::string& base, std::set<std::string>* used) {
  std::string name = base;
  for (int k = 2; used->count(name); ++k) name = base + "_" + std::to_string(k);
  used->insert(name);
  return name;
}

}  // namespace

MakeDataSummary MakeRegistrationData(const MakeDataOptions& o, const std::string& out_dir) {
  o.Check();
  Timer timer;
  CreateDirectories(out_dir);
  const std::string index_path = JoinPaths(out_dir, "pairs.json");
  Json index = {{"pairs", Json::array()}, {"objects", Json::object()}};
  if (FileExists(index_path)) index = ReadJsonFile(index_path);
  index["options"] = o.ToJson();

  std::vector<ObjectSpec> objects;
  std::set<std::string> used;
  for (const auto& m : o.meshes) {
    if (m.rfind("sh3f:", 0) != 0) {
      objects.push_back({UniqueName(fs::path(m).stem().string(), &used), m, 0, o.split, std::nullopt});
      continue;
    }
    const std::string split = m.substr(5);
    std::vector<Sh3fModel> models = ReadSh3fSplit(o.sh3f_split_file, split, o.sh3f_dir);
    if (o.sh3f_limit > 0 && static_cast<int>(models.size()) > o.sh3f_limit) models.resize(o.sh3f_limit);
    for (const auto& f : models) objects.push_back({UniqueName(FurnitureName(f.id), &used), "", 0, split, f});
  }
  for (int k = 0; k < o.procedural; ++k) {
    const unsigned s = o.procedural_seed + k;
    objects.push_back({UniqueName("procedural_" + std::to_string(s), &used), "", s, o.split, std::nullopt});
  }
  MakeDataSummary summary;
  ProgressBar bar("reg make-data", static_cast<std::int64_t>(objects.size()), "obj");
  for (size_t i = 0; i < objects.size(); ++i) {
    const ObjectSpec& spec = objects[i];
    const bool rendered_only = o.render_only && static_cast<int>(i) < o.nerf_objects;
    if (index["objects"].contains(spec.name) ||
        (rendered_only && index.contains("rendered") && index["rendered"].contains(spec.name))) {
      ++summary.objects_skipped;
      bar.Tick();
      continue;
    }
    Timer t;
    TriangleMesh mesh;
    try {
      mesh = LoadObject(spec);
    } catch (const InputError& e) {
      LOG_WARN("{}: skipped ({})", spec.sh3f ? spec.sh3f->id : spec.mesh_path, e.what());
      index["objects"][spec.name] = {{"skipped", e.what()}};
      WriteJsonFile(index_path, index);
      bar.Tick();
      continue;
    }
    CreateDirectories(JoinPaths(out_dir, spec.name));
    // A rendered-only object gets its pairs, synthesised and real, when a later run trains it.
    Json cost = Json::object();
    std::vector<PairRecord> pairs =
        rendered_only ? std::vector<PairRecord>{} : MeshPairs(spec, mesh, o, out_dir, &cost);
    cost["mesh_pairs_seconds"] = t.Seconds();
    if (static_cast<int>(i) < o.nerf_objects) {
      const auto np = NerfPairs(spec, mesh, o, out_dir, &cost);
      pairs.insert(pairs.end(), np.begin(), np.end());
    }
    for (const auto& p : pairs) index["pairs"].push_back(p.ToJson());
    cost["seconds"] = t.Seconds();
    cost["pairs"] = pairs.size();
    cost["mesh"] = spec.sh3f ? spec.sh3f->archive + ":" + spec.sh3f->model : spec.mesh_path;
    if (spec.sh3f) cost["sh3f_id"] = spec.sh3f->id;
    cost["split"] = spec.split;
    index[rendered_only ? "rendered" : "objects"][spec.name] = cost;
    // After every object, so an interrupted run resumes after the last finished object.
    WriteJsonFile(index_path, index);
    summary.pairs += static_cast<int>(pairs.size());
    ++summary.objects_done;
    LOG_INFO("{}: {} pairs in {:.1f} s", spec.name, pairs.size(), t.Seconds());
    bar.Tick();
  }
  bar.Finish();
  summary.seconds = timer.Seconds();
  return summary;
}

}  // namespace nerfreg
