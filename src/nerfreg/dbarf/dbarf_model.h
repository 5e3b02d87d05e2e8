// DBARF as one object: the generalizable NeRF (ResUNet + IBRNet) and the recurrent pose/depth
// network, with their options and one weights file for both.
//
// Weights file: a torch archive holding "meta" (JSON: format tag, version, the effective options,
// and free-form "training" facts such as steps and data) and the three modules' parameters
// ("feature_net", "ibrnet", "pose_net"). Written atomically. Loading names the file and the field
// in an InputError for a missing, foreign or truncated file, another version, or (when an expected
// configuration is given) weights of another configuration.
#pragma once

#include <torch/torch.h>

#include <string>

#include "nerfreg/dbarf/generalizable_nerf.h"
#include "nerfreg/dbarf/pose_depth_net.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

constexpr int kDbarfWeightsVersion = 1;

struct DbarfOptions {
  GeneralizableNerfOptions nerf;
  PoseDepthNetOptions pose;

  // The original sizes, and the CPU configuration that trains on this project's 2-core machines.
  static DbarfOptions Paper();
  static DbarfOptions Cpu();
  // "paper" or "cpu"; throws InputError naming the option otherwise.
  static DbarfOptions Named(const std::string& name);
  // Returns false (and logs why) when a part is invalid.
  bool Check() const;
};

Json DbarfOptionsToJson(const DbarfOptions& options);
// Throws InputError naming the file and field when a field is missing, mistyped or invalid.
DbarfOptions DbarfOptionsFromJson(const JsonField& json);
Json PoseDepthNetOptionsToJson(const PoseDepthNetOptions& options);
PoseDepthNetOptions PoseDepthNetOptionsFromJson(const JsonField& json);

struct DbarfModel {
  explicit DbarfModel(const DbarfOptions& options);

  // Parameter groups of the two optimisers (spec 4): the NeRF's feature net and MLPs, and the
  // pose network.
  std::vector<torch::Tensor> NerfParameters() const;
  std::vector<torch::Tensor> PoseParameters() const { return pose_net->parameters(); }
  void Train(bool on);
  void To(torch::Device device);
  // Where the parameters are (To()'s device; the CPU for a model just built or loaded).
  torch::Device Device() const { return pose_net->parameters().front().device(); }

  DbarfOptions options;
  GeneralizableNerf nerf;
  PoseDepthNet pose_net{nullptr};
  // Facts about how the weights were made (data, steps, seconds), stored in the file.
  Json training = Json::object();
};

void SaveDbarfWeights(const DbarfModel& model, const std::string& path);
// The model built from the options stored in the file. When `expected` is given its options must
// match (InputError "another configuration" otherwise).
DbarfModel LoadDbarfWeights(const std::string& path, const DbarfOptions* expected = nullptr);

}  // namespace nerfreg
