#include "nerfreg/data/ground_truth.h"

namespace nerfreg {

GroundTruthFile::GroundTruthFile(const std::string& path) : path_(path), json_(ReadJsonFile(path)) {}

Sim3d GroundTruthFile::BlockFromWorld(int k) const {
  return Sim3d::FromMatrix(JsonField(json_, path_)["blocks"][static_cast<size_t>(k)]["block_from_world"].Matrix(4, 4));
}

Sim3d GroundTruthFile::TargetFromSource(int source, int target) const {
  const Sim3d source_from_world = BlockFromWorld(source);
  const Sim3d target_from_world = BlockFromWorld(target);
  return target_from_world * source_from_world.Inverse();
}

}  // namespace nerfreg
