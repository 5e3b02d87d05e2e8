#include "nerfreg/reg_data/sh3f_data.h"

#include <algorithm>
#include <cstdint>
#include <map>

#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"

namespace nerfreg {

void Sh3fSplitOptions::Check() const {
  if (train_percent < 0 || val_percent < 0 || train_percent + val_percent > 100) {
    ThrowInputError("sh3f split", "percentages", "train and val percentages >= 0 summing to at most 100");
  }
  if (min_triangles < 1 || max_triangles < min_triangles) {
    ThrowInputError("sh3f split", "triangles", "1 <= min_triangles <= max_triangles");
  }
  if (!(min_thickness >= 0 && min_thickness < 1)) ThrowInputError("sh3f split", "min_thickness", "in [0, 1)");
}

namespace {

std::uint64_t Fnv1a64(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace

std::string Sh3fSplitOf(const std::string& key, const Sh3fSplitOptions& o) {
  const int bucket = static_cast<int>(Fnv1a64(o.salt + ":" + key) % 100);
  return bucket < o.train_percent ? "train" : bucket < o.train_percent + o.val_percent ? "val" : "test";
}

Json MakeSh3fSplit(const Sh3fSplitOptions& o) {
  o.Check();
  std::vector<std::string> catalog_warnings;
  const std::vector<Sh3fModel> models = ReadSh3fCatalogs(o.furniture_dir, &catalog_warnings);
  for (const auto& w : catalog_warnings) LOG_WARN("{}", w);

  // Split keys: the smallest id among models with byte-identical OBJ entries.
  std::map<std::string, ZipReader> archives;
  std::map<std::pair<std::uint32_t, std::int64_t>, std::string> first_of_content;
  std::vector<std::string> keys(models.size());
  std::vector<size_t> by_id(models.size());
  for (size_t k = 0; k < models.size(); ++k) by_id[k] = k;
  std::sort(by_id.begin(), by_id.end(), [&](size_t a, size_t b) { return models[a].id < models[b].id; });
  for (size_t k : by_id) {
    const Sh3fModel& m = models[k];
    if (!archives.count(m.archive)) archives.emplace(m.archive, ZipReader::Open(m.archive));
    const ZipReader& zip = archives.at(m.archive);
    for (const auto& e : zip.entries()) {
      if (e.name != m.model) continue;
      keys[k] = first_of_content.emplace(std::make_pair(e.crc32, e.uncompressed), m.id).first->second;
    }
  }

  Json out = {{"format", "nerfreg-sh3f-split"},
              {"version", 1},
              {"salt", o.salt},
              {"train_percent", o.train_percent},
              {"val_percent", o.val_percent},
              {"furniture_dir", o.furniture_dir},
              {"min_triangles", o.min_triangles},
              {"max_triangles", o.max_triangles},
              {"min_thickness", o.min_thickness},
              {"excluded", Json::object()},
              {"models", Json::object()}};
  std::map<std::string, std::vector<std::pair<std::uint64_t, std::string>>> splits;
  std::map<std::string, int> excluded_by_reason;
  ProgressBar bar("sh3f split", static_cast<std::int64_t>(models.size()), "model");
  for (size_t k = 0; k < models.size(); ++k) {
    const Sh3fModel& m = models[k];
    std::string reason, kind;
    ObjReadReport report;
    TriangleMesh mesh;
    try {
      mesh = LoadSh3fModel(archives.at(m.archive), m, ObjReadOptions(), &report);
    } catch (const InputError& e) {
      reason = e.what();
      kind = "does not load";
    }
    if (reason.empty()) {
      Eigen::Vector3f mn, mx;
      mesh.Bounds(&mn, &mx);
      Eigen::Vector3f side = mx - mn;
      std::sort(side.data(), side.data() + 3);
      const int n = static_cast<int>(mesh.triangles.size());
      if (n < o.min_triangles) {
        kind = "too few triangles";
        reason = kind + " (" + std::to_string(n) + ")";
      } else if (n > o.max_triangles) {
        kind = "too many triangles";
        reason = kind + " (" + std::to_string(n) + ")";
      } else if (side[0] < o.min_thickness * side[2]) {
        kind = "flat";
        reason = "flat (bounding box " + std::to_string(side[0]) + " x " + std::to_string(side[1]) + " x " +
                 std::to_string(side[2]) + " cm)";
      }
      out["models"][m.id] = {{"archive", m.archive.substr(m.archive.rfind('/') + 1)},
                             {"category", m.category},
                             {"triangles", n},
                             {"textures", report.textures},
                             {"missing_textures", report.missing_textures},
                             {"warnings", report.warning_count}};
      if (!keys[k].empty() && keys[k] != m.id) out["models"][m.id]["same_obj_as"] = keys[k];
    }
    if (!reason.empty()) {
      out["excluded"][m.id] = reason;
      ++excluded_by_reason[kind];
    } else {
      const std::string key = keys[k].empty() ? m.id : keys[k];
      splits[Sh3fSplitOf(key, o)].emplace_back(Fnv1a64(o.salt + ":" + m.id), m.id);
    }
    bar.Tick();
  }
  bar.Finish();
  Json counts = {{"models", models.size()}, {"excluded", out["excluded"].size()}};
  for (const auto& [kind, n] : excluded_by_reason) {
    std::string key = "excluded_" + kind;
    std::replace(key.begin(), key.end(), ' ', '_');
    counts[key] = n;
  }
  for (const char* s : {"train", "val", "test"}) {
    auto& list = splits[s];
    std::sort(list.begin(), list.end());
    out[s] = Json::array();
    for (const auto& [hash, id] : list) out[s].push_back(id);
    counts[s] = list.size();
  }
  out["counts"] = counts;
  return out;
}

std::vector<Sh3fModel> ReadSh3fSplit(const std::string& split_file, const std::string& split,
                                     const std::string& furniture_dir) {
  const Json j = ReadJsonFile(split_file);
  if (!j.is_object() || j.value("format", "") != "nerfreg-sh3f-split") {
    ThrowInputError(split_file, "format", "\"nerfreg-sh3f-split\" (models/sh3f_split.json, from reg sh3f-split)");
  }
  if (!j.contains(split) || !j[split].is_array()) ThrowInputError(split_file, split, "a list of model ids");
  std::map<std::string, Sh3fModel> by_id;
  for (auto& m : ReadSh3fCatalogs(furniture_dir)) by_id[m.id] = m;
  std::vector<Sh3fModel> out;
  for (const auto& id : j[split]) {
    if (!id.is_string()) ThrowInputError(split_file, split, "model ids (strings)");
    const auto it = by_id.find(id.get<std::string>());
    if (it == by_id.end()) {
      ThrowInputError(split_file, id.get<std::string>(),
                      "a model of the catalogs in " + furniture_dir + " (another sweethome3d-furniture version?)");
    }
    out.push_back(it->second);
  }
  return out;
}

}  // namespace nerfreg
