#include "nerfreg/dbarf_data/posed_images.h"

#include <filesystem>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"

namespace nerfreg {

namespace fs = std::filesystem;

namespace {

Json ConfidenceToJson(const ImagePoseConfidence& c) {
  Json conf = {{"edges", c.edges},
               {"rotation_residual_deg", c.rotation_residual_deg},
               {"direction_residual_deg", c.direction_residual_deg},
               {"low", c.low}};
  if (c.edges_left_out >= 0) conf["edges_left_out"] = c.edges_left_out;
  if (c.observations >= 0)
    conf["observations"] = c.observations, conf["reprojection_error_px"] = c.reprojection_error_px;
  if (!c.problem.empty()) conf["problem"] = c.problem;
  return conf;
}

}  // namespace

void WritePosedImages(const std::string& path, const PosedImages& posed) {
  Json json = TransformsJsonFromDataset(posed.dataset);
  for (size_t m = 0; m < posed.posed_by.size() && m < posed.confidence.size(); ++m) {
    json["frames"][m]["posed_by"] = posed.posed_by[m];
    json["frames"][m]["confidence"] = ConfidenceToJson(posed.confidence[m]);
  }
  json["not_posed"] = posed.not_posed;
  if (!posed.not_posed_reason.empty()) {
    Json reasons = Json::object();
    for (size_t k = 0; k < posed.not_posed.size() && k < posed.not_posed_reason.size(); ++k)
      reasons[posed.not_posed[k]] = posed.not_posed_reason[k];
    json["not_posed_reason"] = reasons;
  }
  if (!posed.confidence.empty()) {
    json["low_confidence"] = posed.low_confidence;
    json["confidence_doc"] =
        "per frame: the median angles (deg) between the image's pairwise relative rotations / translation "
        "directions and those of the accepted poses, over `edges` of them. sfm: its view-graph (essential-matrix) "
        "edges to other SfM-posed images that the solution was made from (consistent with the averaged rotations; "
        "`edges_left_out` counts the others), plus its triangulated observations and their mean reprojection "
        "error. "
        "network, method network: its view-graph edges against the averaged cameras (its network edges where it has "
        "none). network, method auto: the network's relative "
        "pose between two of its SfM-posed sources (through the image) against the SfM's, per source pair. low: no "
        "edge, rotation residual above --low-confidence-deg, direction residual above 30 deg, or (sfm) fewer than "
        "10 observations, or a problem of the pixels (\"problem\": textureless, identical to another image, or "
        "unrelated to every other).";
  }
  json["view_graph"] = posed.view_graph;
  json["dbarf_poses"] = posed.info;
  WriteJsonFile(path, json);
}

bool IsPosedImages(const Json& json) { return json.is_object() && json.contains("dbarf_poses"); }

PosedImagesInfo ReadPosedImagesInfo(const Json& json, const std::string& path) {
  PosedImagesInfo out;
  const JsonField root(json, path);
  const JsonField graph = root["view_graph"];
  for (size_t e = 0; e < graph.ArraySize(); ++e) {
    out.view_graph.push_back({graph[e][0].String(), graph[e][1].String(), graph[e][2].Int()});
  }
  const JsonField info = root["dbarf_poses"];
  out.near = info["near"].Double();
  out.far = info["far"].Double();
  return out;
}

void WriteRefinedPosedImages(const std::string& input, Dataset refined, const std::string& path) {
  const Json original = ReadJsonFile(TransformsJsonPath(input));
  const fs::path out_dir = fs::absolute(fs::path(path)).parent_path();
  for (Frame& f : refined.frames)
    f.file_path = fs::relative(fs::absolute(refined.ImagePath(f)), out_dir).generic_string();
  refined.root = out_dir.string();
  Json json = TransformsJsonFromDataset(refined);
  for (const char* key : {"view_graph", "not_posed", "dbarf_poses"})
    if (original.contains(key)) json[key] = original[key];
  json["dbarf_poses"]["refined"] = "dbarf finetune --refine-cameras (RGB loss of the NeRF stages)";
  WriteJsonFile(path, json);
}

}  // namespace nerfreg
