#include "nerfreg/dbarf/ibr_render.h"

#include "nerfreg/dbarf/projection.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

IbrRenderOptions IbrRenderOptions::Paper() { return {}; }

IbrRenderOptions IbrRenderOptions::Cpu() {
  IbrRenderOptions o;
  o.num_samples = 32;
  o.chunk_rays = 512;
  return o;
}

bool IbrRenderOptions::Check() const {
  if (num_samples < 2) {
    LOG_ERROR("IbrRenderOptions: num_samples must be >= 2, got {}", num_samples);
    return false;
  }
  if (!(valid_sample_fraction >= 0 && valid_sample_fraction < 1)) {
    LOG_ERROR("IbrRenderOptions: valid_sample_fraction must be in [0, 1), got {}", valid_sample_fraction);
    return false;
  }
  if (chunk_rays < 1) {
    LOG_ERROR("IbrRenderOptions: chunk_rays must be >= 1");
    return false;
  }
  return true;
}

void IbrSourceViews::CheckShapes() const {
  TORCH_CHECK(images.dim() == 4 && images.size(1) == 3 && images.scalar_type() == torch::kFloat,
              "IbrSourceViews: images must be float32 [V,3,H,W], got ", images.sizes());
  const int64_t v = images.size(0);
  TORCH_CHECK(intrinsics.sizes() == torch::IntArrayRef({v, 3, 3}), "IbrSourceViews: intrinsics must be [V,3,3], got ",
              intrinsics.sizes());
  TORCH_CHECK(cam_from_world.sizes() == torch::IntArrayRef({v, 4, 4}),
              "IbrSourceViews: cam_from_world must be [V,4,4], got ", cam_from_world.sizes());
  TORCH_CHECK(features.defined() && features.dim() == 4 && features.size(0) == v,
              "IbrSourceViews: features must be [V,C,h,w]");
}

IbrRays TargetRays(const torch::Tensor& intrinsics, const torch::Tensor& cam_from_world, int64_t height, int64_t width,
                   const torch::Tensor& pixel_indices) {
  TORCH_CHECK(intrinsics.sizes() == torch::IntArrayRef({3, 3}) && cam_from_world.sizes() == torch::IntArrayRef({4, 4}),
              "TargetRays: intrinsics must be [3,3] and cam_from_world [4,4]");
  torch::Tensor idx =
      pixel_indices.defined() ? pixel_indices : torch::arange(height * width, intrinsics.options().dtype(torch::kLong));
  TORCH_CHECK(idx.dim() == 1 && idx.scalar_type() == torch::kLong, "TargetRays: pixel_indices must be int64 [R]");
  const torch::Tensor u = idx.remainder(width).to(torch::kFloat) + 0.5;
  const torch::Tensor v = idx.div(width, "floor").to(torch::kFloat) + 0.5;
  const torch::Tensor pix = torch::stack({u, v, torch::ones_like(u)}, 1);            // [R,3]
  const torch::Tensor dir_cam = torch::matmul(pix, torch::inverse(intrinsics).t());  // z = 1
  const torch::Tensor rot = cam_from_world.narrow(0, 0, 3).narrow(1, 0, 3);
  IbrRays rays;
  rays.directions = torch::matmul(dir_cam, rot);  // R^T d as rows
  rays.origins = CameraCenters(cam_from_world.unsqueeze(0)).expand({idx.size(0), 3});
  return rays;
}

torch::Tensor InverseDepthSamples(int64_t num_rays, int64_t num_samples, double near, double far, bool stratified,
                                  torch::Device device) {
  TORCH_CHECK(near > 0 && far > near, "InverseDepthSamples: need 0 < near < far");
  TORCH_CHECK(num_samples >= 2, "InverseDepthSamples: need >= 2 samples");
  const torch::Tensor inv = torch::linspace(1.0 / near, 1.0 / far, num_samples, torch::TensorOptions().device(device));
  torch::Tensor z = (1.0 / inv).unsqueeze(0).expand({num_rays, num_samples}).contiguous();
  if (!stratified) return z;
  const torch::Tensor mid = 0.5 * (z.narrow(1, 1, num_samples - 1) + z.narrow(1, 0, num_samples - 1));
  const torch::Tensor upper = torch::cat({mid, z.narrow(1, num_samples - 1, 1)}, 1);
  const torch::Tensor lower = torch::cat({z.narrow(1, 0, 1), mid}, 1);
  return lower + (upper - lower) * torch::rand_like(z);
}

IbrRenderOutput CompositeIbr(const torch::Tensor& rgb, const torch::Tensor& sigma, const torch::Tensor& depths) {
  TORCH_CHECK(sigma.dim() == 2 && depths.sizes() == sigma.sizes(), "CompositeIbr: sigma and depths must be [R,S]");
  TORCH_CHECK(rgb.dim() == 3 && rgb.size(2) == 3 && rgb.sizes().slice(0, 2) == sigma.sizes(),
              "CompositeIbr: rgb must be [R,S,3]");
  const torch::Tensor alpha = 1.0 - torch::exp(-sigma);
  const torch::Tensor trans = torch::cumprod(1.0 - alpha + 1e-10, 1);
  const torch::Tensor shifted =
      torch::cat({torch::ones_like(trans.narrow(1, 0, 1)), trans.narrow(1, 0, trans.size(1) - 1)}, 1);
  IbrRenderOutput out;
  out.weights = alpha * shifted;
  out.rgb = (out.weights.unsqueeze(2) * rgb).sum(1);
  out.depth = (out.weights * depths).sum(1);
  return out;
}

IbrRenderOutput RenderIbrRays(IbrNet& net, const IbrSourceViews& sources, const IbrRays& rays, double near, double far,
                              const IbrRenderOptions& options, bool training) {
  TORCH_CHECK(options.Check(), "RenderIbrRays: invalid options");
  sources.CheckShapes();
  TORCH_CHECK(rays.origins.dim() == 2 && rays.origins.size(1) == 3 && rays.directions.sizes() == rays.origins.sizes(),
              "RenderIbrRays: rays must be [R,3]");
  const int64_t r = rays.origins.size(0), s = options.num_samples;
  const int64_t height = sources.images.size(2), width = sources.images.size(3);
  const torch::Tensor z = InverseDepthSamples(r, s, near, far, training, rays.origins.device());           // [R,S]
  const torch::Tensor points = rays.origins.unsqueeze(1) + z.unsqueeze(2) * rays.directions.unsqueeze(1);  // [R,S,3]

  const ProjectedPoints proj = ProjectToViews(points, sources.intrinsics, sources.cam_from_world, height, width);
  const torch::Tensor rgb = SampleViews(sources.images, proj.uv, height, width);     // [V,R,S,3]
  const torch::Tensor feat = SampleViews(sources.features, proj.uv, height, width);  // [V,R,S,C]
  const torch::Tensor ray_diff =
      RayDifference(points, rays.origins, CameraCenters(sources.cam_from_world));  // [V,R,S,4]
  const torch::Tensor mask = proj.Valid().permute({1, 2, 0});                      // [R,S,V]
  const IbrNetOutput raw =
      net->forward(torch::cat({rgb, feat}, 3).permute({1, 2, 0, 3}), ray_diff.permute({1, 2, 0, 3}), mask);

  IbrRenderOutput out = CompositeIbr(raw.rgb, raw.sigma, z);
  const torch::Tensor good_samples = (mask.sum(2) >= 2).sum(1);  // [R]
  out.valid = good_samples.to(torch::kDouble) > options.valid_sample_fraction * s;
  return out;
}

IbrRenderOutput RenderIbrImage(ResUNet& feature_net, IbrNet& net, IbrSourceViews sources,
                               const torch::Tensor& intrinsics, const torch::Tensor& cam_from_world, int64_t height,
                               int64_t width, double near, double far, const IbrRenderOptions& options) {
  TORCH_CHECK(options.Check(), "RenderIbrImage: invalid options");
  torch::NoGradGuard no_grad;
  if (!sources.features.defined()) sources.features = feature_net->NerfFeatures(sources.images);
  const IbrRays all = TargetRays(intrinsics, cam_from_world, height, width);
  const int64_t num_pixels = height * width;
  // On the CPU at most 256 rays a chunk whatever the cap: each chunk's per-view tensors (256 x S x V
  // x 64 floats) then stay near the caches, which made a view faster than 512-ray chunks
  // (docs/threads.md, bench/dbarf_bench.cc). On a GPU, larger chunks fill the device.
  const int64_t chunk_rays = all.origins.is_cuda() ? options.chunk_rays : std::min<int64_t>(options.chunk_rays, 256);
  const int64_t num_chunks = (num_pixels + chunk_rays - 1) / chunk_rays;
  std::vector<torch::Tensor> rgb(num_chunks), depth(num_chunks), valid(num_chunks), weights(num_chunks);
  // Chunks in parallel, each on one thread (torch ops inside a parallel region run serially): the
  // per-sample MLPs are small matrix products that one thread's BLAS call cannot spread over the
  // cores, so chunk-level parallelism keeps them busy (bench/dbarf_bench.cc).
  // (On a GPU the grain of num_chunks keeps it to one thread: the device is what runs in parallel.)
  at::parallel_for(0, num_chunks, all.origins.is_cuda() ? num_chunks : 1, [&](int64_t begin, int64_t end) {
    torch::NoGradGuard no_grad_here;  // grad mode is per thread
    for (int64_t c = begin; c < end; ++c) {
      const int64_t start = c * chunk_rays, n = std::min(chunk_rays, num_pixels - start);
      const IbrRays chunk{all.origins.narrow(0, start, n), all.directions.narrow(0, start, n)};
      const IbrRenderOutput o = RenderIbrRays(net, sources, chunk, near, far, options, false);
      rgb[c] = o.rgb;
      depth[c] = o.depth;
      valid[c] = o.valid;
      weights[c] = o.weights;
    }
  });
  return {torch::cat(rgb), torch::cat(depth), torch::cat(valid), torch::cat(weights)};
}

}  // namespace nerfreg
