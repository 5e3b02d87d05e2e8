// Posed images: the transforms.json `dbarf poses` writes (OUT/transforms.json) and `dbarf finetune`
// / `dbarf render` read back. A transforms.json dataset of the posed images (paths relative to the
// file's folder) plus what DBARF needs beside the cameras: the view graph (neighbours for
// training and rendering), the depth range and how each image was posed. The top-level key
// "dbarf_poses" marks such a file; any other transforms.json is a dataset whose poses are ground
// truth (dbarf_data/dbarf_scene.h).
#pragma once

#include <string>
#include <vector>

#include "nerfreg/data/dataset.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// How well an image's pose agrees with its own measurements (dbarf_sfm/network_poses.h computes it).
struct ImagePoseConfidence {
  int edges = 0;  // pairwise measurements checked (dbarf_sfm/network_poses.h)
  // sfm: the image's view-graph edges its rotation averaging left out (not checked; -1: not sfm).
  int edges_left_out = -1;
  double rotation_residual_deg = 180;  // their median rotation disagreement, degrees (180: none)
  // The same for the translation directions: the angle between the measured direction and the
  // accepted poses' (180: none, or zero translations).
  double direction_residual_deg = 180;
  int observations = -1;              // sfm: triangulated points seen; -1 for network
  double reprojection_error_px = -1;  // sfm: their mean reprojection error; -1 for network
  // What the pixels alone say against any pose of the image (ImageInputProblems); empty: nothing.
  std::string problem;
  bool low = false;
};

struct PosedImages {
  Dataset dataset;  // the posed frames; dataset.root is the file's folder
  // Per frame (empty: not written, as in refined cameras): "sfm" or "network", and its confidence.
  std::vector<std::string> posed_by;
  std::vector<ImagePoseConfidence> confidence;
  std::vector<std::string> not_posed, low_confidence;  // image names
  std::vector<std::string> not_posed_reason;           // one per not_posed (may be empty)
  // [[name_i, name_j, inliers], ...]: the view graph, plus the pairs the network ran on (0 inliers).
  Json view_graph = Json::array();
  // The "dbarf_poses" object: counts, timings, the method, and the depth range ("near", "far").
  Json info = Json::object();
};

// Writes `posed` to `path` (with WriteJsonFile). With per-frame confidences, also "low_confidence"
// and "confidence_doc" (what the confidences measure).
void WritePosedImages(const std::string& path, const PosedImages& posed);

// Whether a parsed transforms.json is posed images (it has "dbarf_poses").
bool IsPosedImages(const Json& json);

// The view graph, depth range and the rest of posed images already parsed from `path` (errors name
// it): the dataset's frames are not read here (data/convert.h reads them with their images).
struct PosedImagesInfo {
  struct Edge {
    std::string a, b;
    int inliers = 0;
  };
  std::vector<Edge> view_graph;
  double near = 0, far = 0;
};
PosedImagesInfo ReadPosedImagesInfo(const Json& json, const std::string& path);

// `dbarf finetune --refine-cameras`: the posed images of `input` (a file or folder) with its frames
// replaced by `refined` (image paths made relative to the output's folder); view graph, images not
// posed and "dbarf_poses" kept, the latter marked "refined".
void WriteRefinedPosedImages(const std::string& input, Dataset refined, const std::string& path);

}  // namespace nerfreg
