// Rendering target rays with the generalizable NeRF (spec dbarf.md 2, "Sampling and rendering"):
// rays through target pixel centres, samples uniform in inverse depth between near and far
// (stratified in training), projection of every sample into the source views, IBRNet aggregation,
// and volume rendering with IBRNet's alpha = 1 - exp(-sigma) (no interval length: sigma is a
// per-sample opacity, which makes it independent of the sample spacing's units).
//
// Feature maps are computed once per set of source views (ResUNetImpl::NerfFeatures) and passed
// in, so one batch of source images serves many chunks of rays.
#pragma once

#include <torch/torch.h>

#include "nerfreg/dbarf/ibrnet.h"
#include "nerfreg/dbarf/resunet.h"

namespace nerfreg {

struct IbrRenderOptions {
  // Samples per ray (coarse only); paper 64.
  int64_t num_samples = 64;
  // A ray is valid when more than num_samples * valid_sample_fraction of its samples have >= 2
  // valid source views; the original's "> 8 samples" at 64 samples is the fraction 1/8.
  double valid_sample_fraction = 0.125;
  // Most rays per chunk in RenderIbrImage (memory: chunk * num_samples * V per-view entries); on
  // the CPU it renders at most 256 a chunk, in parallel chunks.
  int64_t chunk_rays = 1024;

  // The original sizes, and a CPU configuration (fewer samples).
  static IbrRenderOptions Paper();
  static IbrRenderOptions Cpu();
  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

// The source views a target is rendered from.
struct IbrSourceViews {
  torch::Tensor images;          // [V, 3, H, W] float32 in [0, 1]
  torch::Tensor intrinsics;      // [V, 3, 3] float32, pixels
  torch::Tensor cam_from_world;  // [V, 4, 4] float32
  torch::Tensor features;        // [V, C, h, w] float32: ResUNetImpl::NerfFeatures(images)
  // Throws (TORCH_CHECK) when the shapes disagree.
  void CheckShapes() const;
};

struct IbrRays {
  torch::Tensor origins;  // [R, 3] float32: the target camera centre
  // [R, 3] float32, NOT unit: the camera-frame z component is 1, so origin + z * direction is the
  // point at camera depth z and the rendered depth is z-depth (as the original).
  torch::Tensor directions;
};

struct IbrRenderOutput {
  torch::Tensor rgb;      // [R, 3] float32
  torch::Tensor depth;    // [R] float32: expected z-depth, sum(weights * z)
  torch::Tensor valid;    // [R] bool: see IbrRenderOptions::valid_sample_fraction
  torch::Tensor weights;  // [R, S] float32: alpha_i * T_i
};

// Rays through the pixel centres of a target camera (intrinsics [3, 3], cam_from_world [4, 4],
// float32) of an image of size height x width. pixel_indices: [R] int64, row * width + col, or
// undefined for all pixels in row-major order.
IbrRays TargetRays(const torch::Tensor& intrinsics, const torch::Tensor& cam_from_world, int64_t height, int64_t width,
                   const torch::Tensor& pixel_indices = {});

// Sample depths [num_rays, num_samples] float32, increasing, uniform in inverse depth from near to
// far (0 < near < far). Stratified: each sample jittered uniformly within its bin (bins bounded by
// midpoints, the first and last half-bins clamped to near and far). On `device`.
torch::Tensor InverseDepthSamples(int64_t num_rays, int64_t num_samples, double near, double far, bool stratified,
                                  torch::Device device = torch::kCPU);

// Volume rendering of per-sample rgb [R, S, 3] and sigma [R, S] at depths [R, S]:
// alpha = 1 - exp(-sigma), T_i = prod_{j<i} (1 - alpha_j + 1e-10), weights = alpha * T.
// `valid` of the output is left undefined.
IbrRenderOutput CompositeIbr(const torch::Tensor& rgb, const torch::Tensor& sigma, const torch::Tensor& depths);

// Renders rays from the source views: samples (stratified when `training`), projects, runs
// IBRNet, composites. Differentiable in the network, the features and the source cameras.
IbrRenderOutput RenderIbrRays(IbrNet& net, const IbrSourceViews& sources, const IbrRays& rays, double near, double far,
                              const IbrRenderOptions& options, bool training);

// Renders a whole target image without gradients, in chunks of options.chunk_rays rays,
// deterministic samples. Computes the source features with `feature_net` when sources.features is
// undefined. Returns rgb [H*W, 3], depth [H*W], valid [H*W], weights [H*W, S] (row-major pixels).
IbrRenderOutput RenderIbrImage(ResUNet& feature_net, IbrNet& net, IbrSourceViews sources,
                               const torch::Tensor& intrinsics, const torch::Tensor& cam_from_world, int64_t height,
                               int64_t width, double near, double far, const IbrRenderOptions& options);

}  // namespace nerfreg
