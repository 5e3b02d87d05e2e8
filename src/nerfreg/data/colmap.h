#pragma once
// COLMAP sparse models (cameras, images, points3D) in text (.txt) and binary (.bin), as COLMAP 3.x
// reads and writes them. Image poses are cam_from_world with OpenCV axes: COLMAP's own convention,
// so no axis conversion is needed.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "nerfreg/data/dataset.h"
#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct ColmapCamera {
  std::uint32_t camera_id = 0;
  std::string model;  // SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV
  int width = 0, height = 0;
  std::vector<double> params;                                              // in COLMAP's order for the model
  Camera ToCamera() const;                                                 // throws InputError for unsupported models
  static ColmapCamera FromCamera(std::uint32_t id, const Camera& camera);  // PINHOLE or OPENCV
};

struct ColmapPoint2D {
  double x = 0, y = 0;
  std::int64_t point3d_id = -1;  // -1: not triangulated
};

struct ColmapImage {
  std::uint32_t image_id = 0;
  Rigid3d cam_from_world;
  std::uint32_t camera_id = 0;
  std::string name;
  std::vector<ColmapPoint2D> points2d;
};

struct ColmapTrackElement {
  std::uint32_t image_id = 0;
  std::uint32_t point2d_idx = 0;
};

struct ColmapPoint3D {
  std::uint64_t point3d_id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::uint8_t rgb[3] = {0, 0, 0};
  double error = 0;
  std::vector<ColmapTrackElement> track;
};

struct ColmapModel {
  std::map<std::uint32_t, ColmapCamera> cameras;
  std::map<std::uint32_t, ColmapImage> images;
  std::map<std::uint64_t, ColmapPoint3D> points3d;
};

// Reads a model folder; text if cameras.txt exists, else binary. Throws InputError naming the
// file and the line / record on malformed input; counts are checked against the file size before
// allocating.
ColmapModel ReadColmapModel(const std::string& dir);
ColmapModel ReadColmapText(const std::string& dir);
ColmapModel ReadColmapBinary(const std::string& dir);
void WriteColmapText(const ColmapModel& model, const std::string& dir);
void WriteColmapBinary(const ColmapModel& model, const std::string& dir);
bool IsColmapModelDir(const std::string& dir);

// Dataset <-> model. Images are named by Frame::name; the dataset's root is `image_root`.
// A model carries no split: all frames become "train".
Dataset DatasetFromColmap(const ColmapModel& model, const std::string& image_root);
ColmapModel ColmapFromDataset(const Dataset& dataset);

}  // namespace nerfreg
