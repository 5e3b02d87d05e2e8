#pragma once
// A trained NeRF block: the field, its occupancy grid, the marching settings, and the block's
// training cameras (registration marches from them to compute the surface field). Saved as one
// checkpoint file (a torch archive) written atomically, with a format tag and version so a file
// from another tool or version is refused with a clear message.
#include <torch/torch.h>

#include <memory>
#include <string>

#include "nerfreg/data/dataset.h"
#include "nerfreg/nerf/field.h"
#include "nerfreg/nerf/occupancy_grid.h"
#include "nerfreg/nerf/volume_rendering.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

constexpr int kNerfCheckpointVersion = 1;

struct NerfBlock {
  FieldOptions field_options;
  OccupancyGridOptions grid_options;
  MarchOptions march;
  NerfField field{nullptr};
  std::unique_ptr<OccupancyGrid> grid;
  Dataset cameras;  // the block's cameras (frames with splits), in the block's frame
  int step = 0;     // training iterations done
  Json train_options;

  // Builds an untrained block (field initialised from `seed`).
  static NerfBlock Create(const FieldOptions& field_options, const OccupancyGridOptions& grid_options,
                          const MarchOptions& march, unsigned seed);
};

struct RenderedRays {
  torch::Tensor rgb;      // [R, 3] composited over the background
  torch::Tensor opacity;  // [R]
  torch::Tensor depth;    // [R] expected distance along the ray where opacity > 0, else 0
};

// Renders rays without gradients, in chunks. origins, dirs: [R, 3]; background: [3].
RenderedRays RenderRays(NerfBlock& block, const torch::Tensor& origins, const torch::Tensor& dirs,
                        const torch::Tensor& background, std::int64_t chunk = 1 << 14);

// Renders one full image of `camera` at `cam_from_world` over a white background.
Image RenderImage(NerfBlock& block, const Camera& camera, const Rigid3d& cam_from_world);

// origins / directions for all pixels of a camera: [H*W, 3] each, float32.
void CameraRays(const Camera& camera, const Rigid3d& cam_from_world, torch::Tensor* origins, torch::Tensor* dirs);

// Checkpoints. `extra` archives (optimizer state, RNG) may be added by the trainer.
void SaveNerfBlock(const NerfBlock& block, const std::string& path,
                   const std::function<void(torch::serialize::OutputArchive&)>& extra = nullptr);
// Throws InputError naming the file when it is missing, truncated, not a nerfreg NeRF checkpoint,
// or of another version.
// The file is read on the CPU (whatever device wrote it) and the field then moved to `device`.
NerfBlock LoadNerfBlock(const std::string& path,
                        const std::function<void(torch::serialize::InputArchive&)>& extra = nullptr,
                        const torch::Device& device = torch::kCPU);

}  // namespace nerfreg
