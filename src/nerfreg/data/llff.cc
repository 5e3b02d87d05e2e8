#include "nerfreg/data/llff.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "nerfreg/data/npy.h"
#include "nerfreg/geometry/conventions.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"

namespace fs = std::filesystem;

namespace nerfreg {

void LlffOptions::Check() const {
  if (image_dir.empty() || test_every < 0) throw std::invalid_argument("LlffOptions: bad image_dir or test_every");
}

Dataset ReadLlff(const std::string& scene_dir, const LlffOptions& options) {
  options.Check();
  const std::string npy_path = JoinPaths(scene_dir, "poses_bounds.npy");
  const NpyArray a = ReadNpy(npy_path);
  if (a.shape.size() != 2 || a.shape[1] != 17 || a.shape[0] < 1) {
    ThrowInputError(npy_path, "shape", "(N, 17) with N >= 1");
  }
  const std::string image_dir = JoinPaths(scene_dir, options.image_dir);
  if (!DirExists(image_dir)) ThrowInputError(image_dir, "", "a folder of images beside poses_bounds.npy");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(image_dir)) {
    const std::string ext = LowerExtension(e.path().string());
    if (e.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".jpeg"))
      names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  const auto n = static_cast<size_t>(a.shape[0]);
  if (names.size() != n) {
    ThrowInputError(image_dir, "",
                    std::to_string(n) + " images as poses_bounds.npy has rows, found " + std::to_string(names.size()));
  }
  int img_w = 0, img_h = 0, img_c = 0;
  ReadImageSize(JoinPaths(image_dir, names[0]), &img_w, &img_h, &img_c);

  Dataset dataset;
  dataset.root = scene_dir;
  for (size_t k = 0; k < n; ++k) {
    const double* row = a.data.data() + k * 17;
    Matrix3x4d c2w;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) c2w(r, c) = row[r * 5 + c];
    const double h = row[4], w = row[9], f = row[14];
    const std::string field = "row " + std::to_string(k);
    if (!(h > 0 && w > 0 && f > 0)) ThrowInputError(npy_path, field, "positive h, w, focal in column 5");
    Frame frame;
    frame.file_path = JoinPaths(options.image_dir, names[k]);
    frame.name = names[k];
    // The hwf column describes the full-resolution images; scale to the folder's images.
    const double s = img_w / w;
    frame.camera = Camera::Pinhole(img_w, img_h, f * s, f * s, 0.5 * img_w, 0.5 * img_h);
    try {
      frame.cam_from_world = CamFromWorldFromLlff(c2w);
    } catch (const std::invalid_argument& e) {
      ThrowInputError(npy_path, field, std::string("a rotation in columns 1-3 (") + e.what() + ")");
    }
    frame.near = row[15];
    frame.far = row[16];
    if (!(frame.near > 0 && frame.far > frame.near)) ThrowInputError(npy_path, field, "bounds 0 < near < far");
    frame.split = options.test_every > 0 && k % options.test_every == 0 ? "test" : "train";
    dataset.frames.push_back(std::move(frame));
  }
  dataset.Check(npy_path);
  return dataset;
}

void WriteLlffPoses(const Dataset& dataset, const std::string& scene_dir, double default_near, double default_far) {
  std::vector<const Frame*> frames;
  for (const auto& f : dataset.frames) frames.push_back(&f);
  std::sort(frames.begin(), frames.end(), [](const Frame* a, const Frame* b) { return a->name < b->name; });
  NpyArray a;
  a.shape = {static_cast<std::int64_t>(frames.size()), 17};
  a.data.resize(frames.size() * 17);
  for (size_t k = 0; k < frames.size(); ++k) {
    const Frame& f = *frames[k];
    // LLFF stores one focal length and no principal point or distortion: refuse what it would lose.
    const Camera& c = f.camera;
    if (std::abs(c.fx - c.fy) > 1e-6 * c.fx || std::abs(c.cx - 0.5 * c.width) > 1e-6 * c.width ||
        std::abs(c.cy - 0.5 * c.height) > 1e-6 * c.height || c.HasDistortion()) {
      ThrowInputError(
          f.name, "camera",
          "fx == fy, a centred principal point and no distortion (all LLFF can store), got " + c.ToString());
    }
    const Matrix3x4d c2w = LlffFromCamFromWorld(f.cam_from_world);
    double* row = a.data.data() + k * 17;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) row[r * 5 + c] = c2w(r, c);
    row[4] = f.camera.height;
    row[9] = f.camera.width;
    row[14] = f.camera.fx;
    row[15] = f.near > 0 ? f.near : default_near;
    row[16] = f.far > 0 ? f.far : default_far;
  }
  CreateDirectories(scene_dir);
  WriteNpy(JoinPaths(scene_dir, "poses_bounds.npy"), a);
}

}  // namespace nerfreg
