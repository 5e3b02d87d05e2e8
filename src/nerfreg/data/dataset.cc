#include "nerfreg/data/dataset.h"

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

void Dataset::Check(const std::string& source) const {
  if (frames.empty()) ThrowInputError(source, "frames", "at least one frame");
  std::set<std::string> names;
  for (size_t k = 0; k < frames.size(); ++k) {
    const Frame& f = frames[k];
    const std::string field = "frames[" + std::to_string(k) + "]";
    if (!names.insert(f.name).second) ThrowInputError(source, field + ".file_path", "unique image names, '" + f.name + "' repeats");
    if (f.split != "train" && f.split != "test" && f.split != "val") {
      ThrowInputError(source, field + ".split", "\"train\", \"test\" or \"val\", got \"" + f.split + "\"");
    }
    try {
      f.camera.Check();
    } catch (const std::invalid_argument& e) {
      ThrowInputError(source, field, std::string("valid intrinsics (") + e.what() + ")");
    }
  }
}

}  // namespace nerfreg
