#include "nerfreg/pipeline/register_many_blocks.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "nerfreg/data/convert.h"
#include "nerfreg/data/ngp_snapshot.h"
#include "nerfreg/data/sim3_apply.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/nerf/ngp_import.h"
#include "nerfreg/posegraph/pose_graph.h"
#include "nerfreg/reg/registration_input.h"
#include "nerfreg/registration/register_blocks.h"
#include "nerfreg/registration/scale_normalization.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

void ManyBlockRegistrationOptions::Check() const {
  pair.Check();
  for (const auto& [k, capture_from_file] : this->capture_from_file) {
    if (k < 0) ThrowInputError("--dataparser", "", "K=FILE with K an input's index from 0, got " + std::to_string(k));
    CheckScaleInRange(capture_from_file.scale, "--dataparser", "the dataparser's scale");
  }
}

Json ManyBlockRegistrationOptions::ToJson() const {
  Json frames = Json::object();  // --dataparser: input index -> capture_from_file
  for (const auto& [k, capture_from_file] : this->capture_from_file)
    frames[std::to_string(k)] = MatrixToJson(capture_from_file.ToMatrix());
  Json j = pair.ToJson();
  j["capture_from_file"] = frames;
  return j;
}

ManyBlockRegistrationResult RegisterManyBlocks(const std::vector<std::string>& paths,
                                               const ManyBlockRegistrationOptions& options, DregNet* net) {
  options.Check();
  const BlockRegistrationOptions& o = options.pair;
  Timer timer;
  ManyBlockRegistrationResult result;
  // Each warning is logged and kept in the result.
  auto warn = [&result](const char* format, const auto&... args) {
    std::string message = fmt::format(fmt::runtime(format), args...);
    LOG_WARN("{}", message);
    result.warnings.push_back(std::move(message));
  };
  const int n = static_cast<int>(paths.size());
  const bool free_scale = o.scale == ScaleMode::kFree;
  std::vector<std::unique_ptr<RegistrationInput>> inputs;
  std::vector<bool> occupied;  // enough occupied points to register
  // normalized_from_block per input (identity with kFixed): the graph works in the normalised
  // frames; each pair's job normalises on its own and returns poses in the inputs' units.
  std::vector<Sim3d> normalized_from;
  Json normalization = Json::array();
  if (!options.capture_from_file.empty() && options.capture_from_file.rbegin()->first >= n) {
    ThrowInputError("--dataparser", "",
                    fmt::format("K=FILE with K one of the {} inputs' indices (0-{}), got {}", n, n - 1,
                                options.capture_from_file.rbegin()->first));
  }
  for (int k = 0; k < n; ++k) {
    const std::string& p = paths[k];
    const auto frame = options.capture_from_file.find(k);
    result.capture_from_file.push_back(frame == options.capture_from_file.end() ? Sim3d() : frame->second);
    inputs.push_back(LoadRegistrationInput(
        p, o.splats, o.device,
        frame == options.capture_from_file.end() ? std::nullopt : std::optional<Sim3d>(frame->second)));
    const Eigen::Matrix3Xd cloud = inputs.back()->OccupiedPoints(o.min_density, o.seed);
    occupied.push_back(cloud.cols() >= kMinOccupiedPoints);
    if (!occupied.back()) {
      warn("{}: only {} occupied points (density > {}): not registered", p, cloud.cols(), o.min_density);
    } else if (cloud.cols() < 100) {
      warn("{}: only {} occupied points", p, cloud.cols());
    }
    Sim3d nk;
    if (free_scale && occupied.back()) {
      nk = NormalizationFor(cloud, p);
      normalization.push_back(NormalizationJson(nk, OccupiedRadius(cloud)));
    } else {
      normalization.push_back(nullptr);
    }
    normalized_from.push_back(nk);
  }
  // Each pair registered as reg register registers it; the pairs it trusts become edges.
  std::vector<PoseGraphEdge> edges;
  Json edges_json = Json::array();
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (!occupied[i] || !occupied[j]) continue;
      LOG_INFO("pair {} -> {} ({} of {})", i, j, edges_json.size() + 1, n * (n - 1) / 2);
      const BlockRegistrationResult r = RegisterBlocks(*inputs[i], *inputs[j], o, net);
      const bool used = r.status == "registered";
      edges_json.push_back(
          {{"source", i},
           {"target", j},
           {"target_from_source", MatrixToJson(r.target_from_source.ToMatrix())},
           {"scale", r.target_from_source.scale},
           {"confidence", r.confidence},
           {"method", r.method},
           {"status", r.status},
           {"status_reason", r.status_reason},
           {"reverse", r.reverse},
           {"turn_margin", std::isnan(r.turn_margin) ? Json() : Json(r.turn_margin)},
           {"turn_colour_margin", std::isnan(r.turn_colour_margin) ? Json() : Json(r.turn_colour_margin)},
           {"agreeing_candidates", r.agreeing_candidates},
           {"seconds", r.seconds},
           {"used", used},
           {"field", r.field}});
      if (!used) {
        ++result.untrusted;
        warn("{} -> {}: untrusted, not used: {}", paths[i], paths[j], r.status_reason);
        continue;
      }
      PoseGraphEdge e;
      e.i = i;
      e.j = j;
      // Between the normalised frames: normalized_from_j * T * normalized_from_i^-1.
      e.j_from_i = normalized_from[j] * r.target_from_source * normalized_from[i].Inverse();
      e.weight = r.confidence;
      edges.push_back(e);
    }
  }
  // Pairs that disagree with their loops are dropped (a block of another object, a wrong
  // registration), and named: the graph never silently fuses them.
  std::vector<bool> dropped;
  PoseGraphOptions graph;
  graph.estimate_scale = free_scale;
  const PoseGraphResult g = OptimizePoseGraphWithoutOutliers(n, edges, graph, &dropped);
  Json world_from_block = Json::array(), scales = Json::array(), connected = Json::array();
  for (int k = 0; k < n; ++k) {
    // The graph's world is block 0's normalised frame: x_in_block_0 = normalized_from[0]^-1 *
    // world_from_node * normalized_from[k] * x_in_block_k. An input no edge links is left where it
    // is (the identity) and not merged.
    result.world_from_block.push_back(
        g.connected[k] ? normalized_from[0].Inverse() * g.world_from_node[k] * normalized_from[k] : Sim3d());
    world_from_block.push_back(MatrixToJson(result.world_from_block.back().ToMatrix()));
    scales.push_back(result.world_from_block.back().scale);
    connected.push_back(static_cast<bool>(g.connected[k]));
    result.connected.push_back(g.connected[k]);
    if (!g.connected[k]) {
      ++result.unconnected;
      warn("{}: no trusted registration links it to block 0; not registered (left at the identity)", paths[k]);
    }
  }
  size_t used = 0;
  std::vector<int> dropped_edges_of(n, 0), kept_edges_of(n, 0);
  for (size_t e = 0, k = 0; e < edges_json.size(); ++e) {
    if (!edges_json[e]["used"].get<bool>()) continue;
    edges_json[e]["inlier"] = static_cast<bool>(g.edge_inlier[k]);
    edges_json[e]["rotation_residual_deg"] = g.edge_rotation_error_deg[k];
    edges_json[e]["translation_residual"] = g.edge_translation_error[k];
    edges_json[e]["scale_residual"] = g.edge_log_scale_error[k];
    const int i = edges[k].i, j = edges[k].j;
    if (dropped[k]) {
      edges_json[e]["used"] = false;
      edges_json[e]["dropped"] = "disagrees with the other registrations of its loops";
      ++dropped_edges_of[i];
      ++dropped_edges_of[j];
      warn(
          "{} -> {}: registration disagrees with its loops by {:.1f} deg, {:.1f} % in scale; not used (one of these "
          "blocks may not belong to the scene)",
          paths[i], paths[j], g.edge_rotation_error_deg[k], 100 * (std::exp(g.edge_log_scale_error[k]) - 1));
    } else {
      ++kept_edges_of[i];
      ++kept_edges_of[j];
      ++used;
    }
    ++k;
  }
  for (int b = 0; b < n; ++b) {
    if (dropped_edges_of[b] > 0 && dropped_edges_of[b] >= kept_edges_of[b]) {
      warn("{}: {} of its {} registrations disagree with the others: it may not belong to this scene", paths[b],
           dropped_edges_of[b], dropped_edges_of[b] + kept_edges_of[b]);
    }
  }
  const std::string status = result.unconnected == 0 ? "registered" : "untrusted";
  const std::string status_reason =
      result.unconnected == 0
          ? ""
          : fmt::format("{} of the {} inputs are linked to input 0 by no trusted registration and were not registered",
                        result.unconnected, n);
  result.json = {{"status", status},
                 {"status_reason", status_reason},
                 {"untrusted_pairs", result.untrusted},
                 {"world_from_block", world_from_block},
                 {"scale", scales},
                 {"connected", connected},
                 {"normalization", free_scale ? normalization : Json()},
                 {"edges", edges_json},
                 {"seconds", timer.Seconds()},
                 {"blocks", paths}};
  result.json["options"] = options.ToJson();
  result.used_edges = static_cast<int>(used);
  result.pairs = static_cast<int>(edges_json.size());
  return result;
}

namespace {

// Input k is in the world frame (a result without `connected`, built by hand, has every input there).
bool Registered(const ManyBlockRegistrationResult& result, size_t k) {
  return k >= result.connected.size() || result.connected[k];
}

}  // namespace

Splats MergeSplatsInWorld(const std::vector<std::string>& paths, const ManyBlockRegistrationResult& result) {
  std::vector<Splats> moved;
  for (size_t k = 0; k < paths.size() && k < result.world_from_block.size(); ++k) {
    if (!IsSplatPly(paths[k]) || !Registered(result, k)) continue;
    const Sim3d file_from = k < result.capture_from_file.size() ? result.capture_from_file[k] : Sim3d();
    moved.push_back(TransformSplats(ReadSplatPly(paths[k]), result.world_from_block[k] * file_from));
  }
  if (moved.empty()) ThrowInputError("--merged-splats", "", "at least one splat PLY among the inputs");
  int degree = 0;
  std::int64_t total = 0;
  bool normals = true, same_extras = true;
  for (const Splats& s : moved) {
    degree = std::max(degree, s.sh_degree);
    total += s.size();
    normals = normals && s.has_normals();
    same_extras = same_extras && s.extras.size() == moved[0].extras.size();
    for (size_t e = 0; same_extras && e < s.extras.size(); ++e) {
      same_extras = s.extras[e].name == moved[0].extras[e].name && s.extras[e].type == moved[0].extras[e].type;
    }
  }
  Splats out;
  out.Resize(total, degree, normals);
  out.f_rest.setZero();
  if (same_extras) {
    for (const auto& e : moved[0].extras) out.extras.push_back({e.name, e.type, {}});
  }
  const int rest = ShCoefficientCount(degree) - 1;
  std::int64_t at = 0;
  for (const Splats& s : moved) {
    const std::int64_t n = s.size();
    out.position.middleCols(at, n) = s.position;
    if (normals) out.normal.middleCols(at, n) = s.normal;
    out.f_dc.middleCols(at, n) = s.f_dc;
    // Channel c's coefficients 1..K_s - 1 go to the first slots of its block of `rest`.
    const int own = ShCoefficientCount(s.sh_degree) - 1;
    for (int c = 0; c < 3 && own > 0; ++c) out.f_rest.block(c * rest, at, own, n) = s.f_rest.middleRows(c * own, own);
    out.opacity.segment(at, n) = s.opacity;
    out.log_scale.middleCols(at, n) = s.log_scale;
    out.rotation.middleCols(at, n) = s.rotation;
    for (size_t e = 0; e < out.extras.size(); ++e) {
      out.extras[e].values.insert(out.extras[e].values.end(), s.extras[e].values.begin(), s.extras[e].values.end());
    }
    at += n;
  }
  return out;
}

int WriteMergedCameras(const std::vector<std::string>& paths, const ManyBlockRegistrationResult& result,
                       const std::string& out, const std::map<int, std::string>& splat_cameras) {
  for (const auto& [k, path] : splat_cameras) {
    if (k < 0 || k >= static_cast<int>(paths.size())) {
      ThrowInputError("--cameras", "",
                      fmt::format("K=FILE with K one of the {} inputs' indices, got {} ({})", paths.size(), k, path));
    }
  }
  Dataset merged;
  std::vector<std::vector<int>> blocks_of;  // per kept frame: the inputs that have its image
  std::vector<double> centre_spread, rotation_spread_deg;
  std::map<std::string, size_t> kept;  // absolute image path -> frame index
  for (size_t k = 0; k < paths.size() && k < result.world_from_block.size(); ++k) {
    if (!Registered(result, k)) continue;
    // Input k's cameras in its capture's frame: a block's own, or those given for a splat capture.
    Dataset cameras;
    const auto given = splat_cameras.find(static_cast<int>(k));
    if (given != splat_cameras.end()) {
      cameras = ReadCameras(given->second);
    } else if (IsSplatPly(paths[k])) {
      continue;
    } else {
      NerfBlock block = IsNgpSnapshotPath(paths[k]) ? SnapshotToNerfBlock(ReadNgpSnapshot(paths[k]), paths[k])
                                                    : LoadNerfBlock(paths[k]);
      cameras = std::move(block.cameras);
      if (k < result.capture_from_file.size()) MoveCameras(&cameras, result.capture_from_file[k]);
    }
    MoveCameras(&cameras, result.world_from_block[k]);
    for (Frame f : cameras.frames) {
      f.file_path = std::filesystem::absolute(cameras.ImagePath(f)).lexically_normal().string();
      const auto [at, is_new] = kept.emplace(f.file_path, merged.frames.size());
      if (is_new) {
        merged.frames.push_back(std::move(f));
        blocks_of.push_back({static_cast<int>(k)});
        centre_spread.push_back(0), rotation_spread_deg.push_back(0);
        continue;
      }
      // An image several blocks were trained on: its first camera is kept, and how far the others
      // land from it in the world frame says how well the blocks agree.
      const Frame& first = merged.frames[at->second];
      blocks_of[at->second].push_back(static_cast<int>(k));
      const double d = (first.cam_from_world.Inverse().translation - f.cam_from_world.Inverse().translation).norm();
      centre_spread[at->second] = std::max(centre_spread[at->second], d);
      rotation_spread_deg[at->second] = std::max(
          rotation_spread_deg[at->second], RotationErrorDeg(first.cam_from_world.rotation, f.cam_from_world.rotation));
    }
  }
  if (merged.frames.empty()) {
    ThrowInputError("--merged-cameras", "",
                    "at least one block checkpoint with cameras among the inputs, or --cameras for a splat input");
  }
  Json j = TransformsJsonFromDataset(merged);
  for (size_t i = 0; i < merged.frames.size(); ++i) {
    Json& f = j["frames"][i];
    f["block"] = blocks_of[i][0];
    f["block_path"] = paths[blocks_of[i][0]];
    if (blocks_of[i].size() > 1) {
      f["blocks"] = blocks_of[i];
      f["spread"] = {{"centre", centre_spread[i]}, {"rotation_deg", rotation_spread_deg[i]}};
    }
  }
  WriteJsonFile(out, j);
  return static_cast<int>(merged.frames.size());
}

}  // namespace nerfreg
