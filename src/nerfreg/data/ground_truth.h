#pragma once
// ground_truth.json of a rendered dataset (`nerfreg render --blocks K`, render/render_dataset.h):
// {"blocks": [{"block_from_world": 4x4, "scale", "frames"}, ...]}, each block's random frame. Read
// here once for everyone who scores a registration against it.
#include <string>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

class GroundTruthFile {
 public:
  // Reads the JSON; throws InputError naming the file when it cannot be read or parsed.
  explicit GroundTruthFile(const std::string& path);

  // blocks[k].block_from_world. Throws InputError naming the file and field when it is missing,
  // and std::invalid_argument when the matrix is not a similarity.
  Sim3d BlockFromWorld(int k) const;
  // The true target_from_source between two blocks: block_from_world[target] * block_from_world[source]^-1.
  Sim3d TargetFromSource(int source, int target) const;

 private:
  std::string path_;
  Json json_;
};

}  // namespace nerfreg
