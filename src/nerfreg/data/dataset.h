#pragma once
// A posed image collection: what every format loader produces and every writer consumes.
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct Frame {
  std::string file_path;  // as written in the source file (relative to Dataset::root)
  std::string name;       // unique image name, e.g. "r_017.png" (same view in every block)
  Camera camera;
  Rigid3d cam_from_world;       // OpenCV axes (geometry/conventions.h)
  std::string split = "train";  // "train" or "test"
  // Optional depth bounds of the scene seen by this view (LLFF near/far), 0 if unknown.
  double near = 0, far = 0;
};

struct Dataset {
  std::string root;  // directory image paths are relative to
  std::vector<Frame> frames;
  // instant-ngp fields, kept so files we read and write back keep them.
  std::optional<int> aabb_scale;
  std::optional<double> ngp_scale;
  std::optional<Eigen::Vector3d> ngp_offset;
  // Axis-aligned box containing the content, world frame (min, max); optional.
  std::optional<Eigen::Vector3d> aabb_min, aabb_max;
  // nerfstudio fields, kept so files we read and write back keep them:
  //  - applied_transform ([3, 4]): what ns-process-data applied to the source (COLMAP) poses to
  //    get these; data_from_colmap, written back unchanged unless the poses are moved;
  //  - dataparser_transforms.json (transform, then scale): maps this frame into the one the
  //    nerfstudio model was trained in; trained_from_data.
  std::optional<Eigen::Matrix<double, 3, 4>> applied_transform;
  std::optional<Sim3d> trained_from_data;

  std::vector<int> IndicesOfSplit(const std::string& split) const;
  // Absolute (or root-relative) image path of a frame.
  std::string ImagePath(const Frame& frame) const;
  // Throws InputError naming `source` if frames are empty, names collide, or cameras invalid.
  void Check(const std::string& source) const;
};

}  // namespace nerfreg
