#include "nerfreg/data/dataset.h"

#include <cmath>

#include <set>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

std::vector<int> Dataset::IndicesOfSplit(const std::string& split) const {
  std::vector<int> out;
  for (size_t k = 0; k < frames.size(); ++k)
    if (frames[k].split == split) out.push_back(static_cast<int>(k));
  return out;
}

std::string Dataset::ImagePath(const Frame& frame) const {
  if (!frame.file_path.empty() && frame.file_path[0] == '/') return frame.file_path;
  return JoinPaths(root, frame.file_path);
}

namespace {
constexpr double kMaxFocalPx = 1e6;
constexpr double kMaxCoordinate = 1e7;
}  // namespace

void Dataset::Check(const std::string& source) const {
  if (frames.empty()) ThrowInputError(source, "frames", "at least one frame");
  std::set<std::string> names;
  for (size_t k = 0; k < frames.size(); ++k) {
    const Frame& f = frames[k];
    const std::string field = "frames[" + std::to_string(k) + "]";
    if (!names.insert(f.name).second)
      ThrowInputError(source, field + ".file_path", "unique image names, '" + f.name + "' repeats");
    if (f.split != "train" && f.split != "test" && f.split != "val") {
      ThrowInputError(source, field + ".split", "\"train\", \"test\" or \"val\", got \"" + f.split + "\"");
    }
    try {
      f.camera.Check();
    } catch (const std::invalid_argument& e) {
      ThrowInputError(source, field, std::string("valid intrinsics (") + e.what() + ")");
    }
    // Magnitudes no capture has: float32 training and rendering lose all precision long before,
    // and 1e308 overflows to inf in the first product. A focal length of 1e6 px is a 0.6 deg field
    // of view at 10k px; 1e7 scene units hold georeferenced coordinates.
    const Camera& c = f.camera;
    if (c.fx > kMaxFocalPx || c.fy > kMaxFocalPx) {
      ThrowInputError(source, field + ".fl_x", "a focal length of at most 1e6 pixels, got " + c.ToString());
    }
    if (std::fabs(c.cx) > kMaxFocalPx || std::fabs(c.cy) > kMaxFocalPx || c.width > 100000 || c.height > 100000) {
      ThrowInputError(source, field, "a principal point and image size within 1e5 pixels, got " + c.ToString());
    }
    if (!f.cam_from_world.translation.allFinite() || f.cam_from_world.translation.norm() > kMaxCoordinate ||
        !f.cam_from_world.rotation.coeffs().allFinite()) {
      ThrowInputError(source, field + ".transform_matrix", "a finite camera position within 1e7 scene units");
    }
    if (f.near < 0 || f.far < 0 || !std::isfinite(f.near) || !std::isfinite(f.far) || f.far > kMaxCoordinate) {
      ThrowInputError(source, field, "near / far bounds that are finite, >= 0 and at most 1e7");
    }
  }
}

}  // namespace nerfreg
