#pragma once
// What registration asks of each of its two inputs, whatever the input is, so `reg register`
// takes NeRF block checkpoints and 3D Gaussian splat PLYs alike (and one of each):
//  - a density field (DensityField: sigma at points of the input's frame, and the box it is known
//    in) for the field refinement and the confidence;
//  - DReg-NeRF's voxel grid (the network, FPFH + RANSAC on grids, grid ICP);
//  - occupied points (FPFH + RANSAC / FGR, block ICP, the overlays).
// A NeRF block answers from its field (nerf/field_queries.h); a splat set from its SplatField.
#include <torch/torch.h>

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>

#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/reg/splat_field.h"

namespace nerfreg {

class RegistrationInput {
 public:
  virtual ~RegistrationInput() = default;
  // "nerf" or "splats" (written into T.json).
  virtual std::string Kind() const = 0;
  virtual DensityField Field() = 0;
  virtual RegGrid ExtractGrid(const GridExtractionOptions& options) = 0;
  // One jittered point per occupied cell whose density exceeds min_density: [3, N], input frame.
  // shell: only the boundary of that dense set (a block's solid as the surface a capture of
  // splats is; splats are a surface already and ignore it).
  virtual Eigen::Matrix3Xd OccupiedPoints(double min_density, unsigned seed, bool shell = false) = 0;
  // Moves the input into another frame, x_new = new_from_old * x_old: every later query takes and
  // answers points of the new frame. Scale-free registration brings each input to a common size
  // this way before any method sees it (registration/scale_normalization.h), and back after.
  virtual void Move(const Sim3d& new_from_old) = 0;

  // The file the input was read from (LoadRegistrationInput), which errors about it name; "" for
  // an input built in memory.
  const std::string& Path() const { return path_; }
  void SetPath(std::string path) { path_ = std::move(path); }

 private:
  std::string path_;
};

// A NeRF block, borrowed or owned.
class NerfBlockInput : public RegistrationInput {
 public:
  explicit NerfBlockInput(NerfBlock& block) : block_(&block) {}
  explicit NerfBlockInput(NerfBlock&& block)
      : owned_(std::make_unique<NerfBlock>(std::move(block))), block_(owned_.get()) {}
  std::string Kind() const override { return "nerf"; }
  DensityField Field() override { return BlockDensityField(*block_); }
  RegGrid ExtractGrid(const GridExtractionOptions& options) override { return ExtractRegGrid(*block_, options); }
  Eigen::Matrix3Xd OccupiedPoints(double min_density, unsigned seed, bool shell = false) override;
  // MoveNerfBlock: the field is not resampled, its densities are per unit length of the new frame.
  void Move(const Sim3d& new_from_old) override { MoveNerfBlock(block_, new_from_old); }
  NerfBlock& block() { return *block_; }

 private:
  std::unique_ptr<NerfBlock> owned_;
  NerfBlock* block_;
};

// A splat set. Its occupied points come from a grid over the splats' bounds with cells of
// 1/kSplatOccupancyResolution of its longest side, as a NeRF block's come from its 128^3
// occupancy grid; its registration grid is centred on those bounds.
class SplatInput : public RegistrationInput {
 public:
  static constexpr int kSplatOccupancyResolution = 128;
  SplatInput(const Splats& splats, const SplatFieldOptions& options) : splats_(splats), field_(splats, options) {}
  std::string Kind() const override { return "splats"; }
  DensityField Field() override;
  RegGrid ExtractGrid(const GridExtractionOptions& options) override;
  Eigen::Matrix3Xd OccupiedPoints(double min_density, unsigned seed, bool shell = false) override;
  // The splats moved (TransformSplats) and the field rebuilt from them with the same options: a
  // splat's density is its opacity-weighted Gaussian, so densities do not change with the scale;
  // the blur (options().blur) is in the new frame's units.
  void Move(const Sim3d& new_from_old) override;
  const SplatField& field() const { return field_; }

 private:
  Splats splats_;
  SplatField field_;
};

// positions [N, 3] (any float dtype) -> sigma [N] float32, and rgb [N, 3] with `rgb`.
torch::Tensor SplatDensity(const SplatField& field, const torch::Tensor& positions, torch::Tensor* rgb = nullptr);

// Fewer splats than this in a splat PLY is no capture to register (InputError naming the file).
inline constexpr int kMinSplats = 100;

// A splat PLY (data/splat_ply.h: IsSplatPly), an instant-ngp snapshot (.ingp, .msgpack: imported
// as `nerf import` does, in the frame of the transforms.json it was trained on, from the scale and
// offset it stores), or else a NeRF block checkpoint, loaded; InputError naming the file when it
// is none of them, or a splat PLY with fewer than kMinSplats splats. The block's field goes to
// `device`. The input's Path() is `path`.
//
// `capture_from_file`: where the file is not in its capture's own frame. nerfstudio trains, and
// `ns-export gaussian-splat` writes, in its dataparser's frame, p_file = s (R p_capture + t)
// (dataparser_transforms.json; ReadDataparserTransforms gives file_from_capture). Given its
// inverse, the input is moved into the capture's frame on load, so that it registers, and its
// result is written, in the units the capture's cameras are in.
std::unique_ptr<RegistrationInput> LoadRegistrationInput(const std::string& path,
                                                         const SplatFieldOptions& splat_options,
                                                         const torch::Device& device = torch::kCPU,
                                                         const std::optional<Sim3d>& capture_from_file = {});

// True for the snapshot files LoadRegistrationInput imports (.ingp, .msgpack).
bool IsNgpSnapshotPath(const std::string& path);

}  // namespace nerfreg
