// DBARF's generalizable NeRF as one object: the ResUNet feature extractor and the IBRNet
// aggregation network with their rendering options, and its checkpoint file.
//
// Checkpoint: one torch archive holding "meta" (JSON as uint8 bytes: format tag, version and the
// effective options) and the two modules' parameters ("feature_net", "ibrnet"). Written atomically
// (temp file + rename). Loading names the file and the offending field in an InputError for a
// missing, foreign or truncated file, another version, or a configuration other than the one
// expected.
#pragma once

#include <torch/torch.h>

#include <string>
#include <vector>

#include "nerfreg/dbarf/ibr_render.h"
#include "nerfreg/dbarf/ibrnet.h"
#include "nerfreg/dbarf/resunet.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

constexpr int kGeneralizableNerfCheckpointVersion = 1;

struct GeneralizableNerfOptions {
  // The feature extractor; its nerf_channels must equal ibrnet.feature_channels.
  ResUNetOptions features;
  // The aggregation network.
  IbrNetOptions ibrnet;
  // Sampling and rendering.
  IbrRenderOptions render;

  // The original sizes, and the CPU configuration (ResUNet / IbrNet / IbrRender ::Cpu()).
  static GeneralizableNerfOptions Paper();
  static GeneralizableNerfOptions Cpu();
  // Returns false (and logs why) when a part is invalid or the parts disagree.
  bool Check() const;
};

// The effective options as JSON (written next to outputs and into checkpoints), and back; FromJson
// throws InputError naming the file and field when a field is missing, mistyped or invalid.
Json GeneralizableNerfOptionsToJson(const GeneralizableNerfOptions& options);
GeneralizableNerfOptions GeneralizableNerfOptionsFromJson(const JsonField& json);

struct GeneralizableNerf {
  explicit GeneralizableNerf(const GeneralizableNerfOptions& options);

  // The two parameter groups of DBARF's NeRF optimiser (feature lr, mlp lr; spec 4).
  std::vector<torch::Tensor> FeatureParameters() const { return feature_net->parameters(); }
  std::vector<torch::Tensor> MlpParameters() const { return ibrnet->parameters(); }

  // Source views with their features computed (with the current grad mode): images [V, 3, H, W]
  // float32 in [0, 1], intrinsics [V, 3, 3], cam_from_world [V, 4, 4].
  IbrSourceViews PrepareSources(const torch::Tensor& images, const torch::Tensor& intrinsics,
                                const torch::Tensor& cam_from_world);
  // RenderIbrRays with this model's options.
  IbrRenderOutput RenderRays(const IbrSourceViews& sources, const IbrRays& rays, double near, double far,
                             bool training);

  GeneralizableNerfOptions options;
  ResUNet feature_net{nullptr};
  IbrNet ibrnet{nullptr};
};

// A lower bound on the parameters the options imply (resunet.cc, ibrnet.cc: the 7x7 stem, the 3x3
// residual blocks, the decoder convolutions, and IBRNet's first layers, whose width follows the
// features): loaders check that a file can hold them before allocating (CheckArchiveCanHold).
double GeneralizableNerfParameterLowerBound(const GeneralizableNerfOptions& options);

// Writes the checkpoint atomically (creating parent directories).
void SaveGeneralizableNerf(const GeneralizableNerf& model, const std::string& path);

// Reads a checkpoint into a model built from the options stored in it. When `expected` is given,
// the stored options must equal it (compared as JSON), else InputError ("another configuration").
GeneralizableNerf LoadGeneralizableNerf(const std::string& path, const GeneralizableNerfOptions* expected = nullptr);

}  // namespace nerfreg
