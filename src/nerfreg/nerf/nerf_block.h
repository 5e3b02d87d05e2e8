#pragma once
// A trained NeRF block: the field, its occupancy grid, the marching settings, and the block's
// training cameras (registration marches from them to compute the surface field). Saved as one
// checkpoint file (a torch archive) written atomically, with a format tag and version so a file
// from another tool or version is refused with a clear message.
#include <torch/torch.h>

#include <memory>
#include <string>

#include "nerfreg/data/dataset.h"
#include "nerfreg/geometry/rigid3.h"
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
  // The block's frame relative to the one its field was trained in: x = world_from_field * x_field.
  // Identity for a trained or imported block; `reg apply` moves a block by changing it (and the
  // cameras), not by resampling the field. Every query below (density, colour, rendering, the
  // surface field, occupied points, meshes, grids) takes and returns points of the block's frame;
  // densities are per unit length of that frame (sigma_field / scale).
  Sim3d world_from_field;

  // Whether world_from_field is not the identity (training refuses such a block).
  bool Moved() const;
  // The device the field lives on (its hash table's); rendering and the field queries run there.
  torch::Device Device() const;
  // Moves the field and the occupancy grid to `device`.
  void To(const torch::Device& device);

  // Builds an untrained block (field initialised from `seed`).
  static NerfBlock Create(const FieldOptions& field_options, const OccupancyGridOptions& grid_options,
                          const MarchOptions& march, unsigned seed);
};

struct RenderedRays {
  torch::Tensor rgb;      // [R, 3] composited over the background
  torch::Tensor opacity;  // [R]
  torch::Tensor depth;    // [R] expected distance along the ray where opacity > 0, else 0
};

// Density and colour at points of the block's frame (world_from_field applied): positions [N, 3]
// float32 -> sigma [N]; dirs [N, 3] unit viewing directions -> rgb [N, 3]. No gradients.
torch::Tensor BlockDensity(NerfBlock& block, const torch::Tensor& positions);
std::pair<torch::Tensor, torch::Tensor> BlockForward(NerfBlock& block, const torch::Tensor& positions,
                                                     const torch::Tensor& dirs);
// Positions [N, 3] of the block's frame in the field's frame, and directions rotated there.
torch::Tensor ToFieldFrame(const NerfBlock& block, const torch::Tensor& positions);
torch::Tensor DirectionsToFieldFrame(const NerfBlock& block, const torch::Tensor& dirs);
// Positions [N, 3] of the field's frame in the block's frame.
torch::Tensor FromFieldFrame(const NerfBlock& block, const torch::Tensor& positions);

// Renders rays without gradients, in chunks. origins, dirs: [R, 3]; background: [3]. Marching,
// the field and compositing run on the block's Device() (the rays are moved there once); the
// results are returned on the origins' device.
RenderedRays RenderRays(NerfBlock& block, const torch::Tensor& origins, const torch::Tensor& dirs,
                        const torch::Tensor& background, std::int64_t chunk = 1 << 14);

// Renders one full image of `camera` at `cam_from_world` over a white background.
Image RenderImage(NerfBlock& block, const Camera& camera, const Rigid3d& cam_from_world);

// origins / directions for all pixels of a camera: [H*W, 3] each, float32.
void CameraRays(const Camera& camera, const Rigid3d& cam_from_world, torch::Tensor* origins, torch::Tensor* dirs);

// Moves a block into another frame without resampling its field: world_from_field becomes
// new_from_old * world_from_field (exactly the identity again when that is within 1e-12 of it,
// so T then T^-1 gives back a block training accepts), the cameras move as Sim3d::TransformCamera
// moves them, their near / far bounds scale, and the cameras' aabb becomes the box around the moved one.
void MoveNerfBlock(NerfBlock* block, const Sim3d& new_from_old);

// Checkpoints. `extra` archives (optimizer state, RNG) may be added by the trainer. The field and
// the grid are written as CPU tensors whatever their device, so a block trained on a GPU loads on
// a machine without one; `extra` must write CPU tensors too.
void SaveNerfBlock(const NerfBlock& block, const std::string& path,
                   const std::function<void(torch::serialize::OutputArchive&)>& extra = nullptr);
// Throws InputError naming the file when it is missing, truncated, not a nerfreg NeRF checkpoint,
// or of another version.
// The file is read on the CPU (whatever device wrote it) and the field and grid then moved to
// `device`.
NerfBlock LoadNerfBlock(const std::string& path,
                        const std::function<void(torch::serialize::InputArchive&)>& extra = nullptr,
                        const torch::Device& device = torch::kCPU);

}  // namespace nerfreg
