// CUDA kernels of ray marching and compositing (see volume_rendering.h): one thread per ray, the
// loops of the CPU kernels in volume_rendering.cc line for line.
//
// Marching decides discretely (is this sample's cell occupied? is t still below t1?), so its
// arithmetic is written with round-to-nearest intrinsics that nvcc cannot contract into FMAs: the
// CPU build (baseline x86-64, no FMA) rounds every product and sum, and so must the GPU for the
// samples to be the same. Compositing is continuous and keeps nvcc's contraction: its results
// differ from the CPU kernel's at float rounding only (expf differs by an ulp or two as well).
#include <ATen/ATen.h>
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>

#include "nerfreg/nerf/volume_rendering_cuda.h"

namespace nerfreg {
namespace {

constexpr int kThreads = 128;

unsigned Blocks(std::int64_t work) { return static_cast<unsigned>((work + kThreads - 1) / kThreads); }

// One ray through the AABB, stepping over empty cells: kFill false counts the samples, true also
// writes them from index k on.
template <bool kFill>
__device__ std::int64_t MarchRay(const MarchParams& p, const float* oo, const float* dd, const bool* __restrict__ occ,
                                 float jit, std::int64_t r, std::int64_t k, float* __restrict__ ts,
                                 float* __restrict__ te, std::int64_t* __restrict__ ids) {
  float t0 = p.near, t1 = 1e30f;
  for (int d = 0; d < 3; ++d) {  // slab test against the AABB
    const float inv = __fdiv_rn(1.f, fabsf(dd[d]) > 1e-12f ? dd[d] : 1e-12f);
    float ta = __fmul_rn(__fsub_rn(p.aabb_min[d], oo[d]), inv), tb = __fmul_rn(__fsub_rn(p.aabb_max[d], oo[d]), inv);
    if (ta > tb) {
      const float s = ta;
      ta = tb;
      tb = s;
    }
    t0 = t0 < ta ? ta : t0;  // std::max(t0, ta)
    t1 = tb < t1 ? tb : t1;  // std::min(t1, tb)
  }
  if (!(t1 > t0)) return 0;
  const int G = p.resolution;
  std::int64_t n = 0;
  for (float t = __fadd_rn(t0, __fmul_rn(jit, p.step)); t < t1 && n < p.max_samples; t = __fadd_rn(t, p.step)) {
    int c[3];
    bool in = true;
    for (int d = 0; d < 3; ++d) {
      const float x = __fadd_rn(oo[d], __fmul_rn(t, dd[d]));
      c[d] = static_cast<int>(__fmul_rn(__fsub_rn(x, p.aabb_min[d]), p.inv_cell[d]));
      in = in && c[d] >= 0 && c[d] < G;
    }
    if (!in || !occ[(static_cast<std::int64_t>(c[0]) * G + c[1]) * G + c[2]]) continue;
    if (kFill) {
      ts[k + n] = __fsub_rn(t, p.half_step);
      te[k + n] = __fadd_rn(t, p.half_step);
      ids[k + n] = r;
    }
    ++n;
  }
  return n;
}

__global__ void MarchCountKernel(const float* __restrict__ origins, const float* __restrict__ dirs,
                                 const bool* __restrict__ occ, const float* __restrict__ jitter,
                                 std::int64_t* __restrict__ counts, std::int64_t R, MarchParams p) {
  const std::int64_t r = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r >= R) return;
  const float jit = jitter ? jitter[r] : 0.5f;
  counts[r] = MarchRay<false>(p, origins + 3 * r, dirs + 3 * r, occ, jit, r, 0, nullptr, nullptr, nullptr);
}

__global__ void MarchFillKernel(const float* __restrict__ origins, const float* __restrict__ dirs,
                                const bool* __restrict__ occ, const float* __restrict__ jitter,
                                const std::int64_t* __restrict__ offsets, float* __restrict__ ts,
                                float* __restrict__ te, std::int64_t* __restrict__ ids, std::int64_t R, MarchParams p) {
  const std::int64_t r = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r >= R) return;
  const float jit = jitter ? jitter[r] : 0.5f;
  MarchRay<true>(p, origins + 3 * r, dirs + 3 * r, occ, jit, r, offsets[r], ts, te, ids);
}

__global__ void CompositeForwardKernel(const float* __restrict__ sg, const float* __restrict__ cl,
                                       const float* __restrict__ a, const float* __restrict__ b,
                                       const std::int64_t* __restrict__ off, float* __restrict__ oc,
                                       float* __restrict__ oo, float* __restrict__ od, std::int64_t R, float stop) {
  const std::int64_t r = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r >= R) return;
  float T = 1.f, c0 = 0, c1 = 0, c2 = 0, acc = 0, dep = 0;
  for (std::int64_t i = off[r]; i < off[r + 1]; ++i) {
    const float delta = b[i] - a[i];
    const float alpha = 1.f - expf(-sg[i] * delta);
    const float w = T * alpha;
    c0 += w * cl[3 * i];
    c1 += w * cl[3 * i + 1];
    c2 += w * cl[3 * i + 2];
    acc += w;
    dep += w * 0.5f * (a[i] + b[i]);
    T *= 1.f - alpha;
    if (T < stop) break;
  }
  oc[3 * r] = c0;
  oc[3 * r + 1] = c1;
  oc[3 * r + 2] = c2;
  oo[r] = acc;
  od[r] = dep;
}

// Walks the ray again, rebuilding the running sums colour_{<=i}, opacity_{<=i}, depth_{<=i}; the
// totals come from the forward's outputs.
__global__ void CompositeBackwardKernel(const float* __restrict__ sg, const float* __restrict__ cl,
                                        const float* __restrict__ a, const float* __restrict__ b,
                                        const std::int64_t* __restrict__ off, const float* __restrict__ C,
                                        const float* __restrict__ A, const float* __restrict__ D,
                                        const float* __restrict__ pgc, const float* __restrict__ pgo,
                                        const float* __restrict__ pgd, float* __restrict__ ps, float* __restrict__ pr,
                                        std::int64_t R, float stop) {
  const std::int64_t r = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r >= R) return;
  const float gc[3] = {pgc[3 * r], pgc[3 * r + 1], pgc[3 * r + 2]};
  const float Ct[3] = {C[3 * r], C[3 * r + 1], C[3 * r + 2]};
  const float go = pgo[r], gd = pgd[r], At = A[r], Dt = D[r];
  float T = 1.f, c[3] = {0, 0, 0}, acc = 0, dep = 0;
  for (std::int64_t i = off[r]; i < off[r + 1]; ++i) {
    const float delta = b[i] - a[i];
    const float alpha = 1.f - expf(-sg[i] * delta);
    const float w = T * alpha;
    const float t_mid = 0.5f * (a[i] + b[i]);
    for (int k = 0; k < 3; ++k) {
      c[k] += w * cl[3 * i + k];
      pr[3 * i + k] = w * gc[k];
    }
    acc += w;
    dep += w * t_mid;
    const float T_next = T * (1.f - alpha);
    float g = 0;
    for (int k = 0; k < 3; ++k) g += gc[k] * (T_next * cl[3 * i + k] - (Ct[k] - c[k]));
    g += go * (T_next - (At - acc));
    g += gd * (T_next * t_mid - (Dt - dep));
    ps[i] = delta * g;
    T = T_next;
    if (T < stop) break;
  }
}

void CheckOnOneCudaDevice(const char* what, std::initializer_list<const at::Tensor*> tensors) {
  const at::Device device = (*tensors.begin())->device();
  for (const at::Tensor* t : tensors) {
    TORCH_CHECK(t->is_cuda() && t->device() == device && t->is_contiguous(), what,
                ": tensors must be contiguous and on one CUDA device");
  }
}

}  // namespace

std::array<at::Tensor, 4> MarchRaysCuda(const at::Tensor& origins, const at::Tensor& dirs, const at::Tensor& occupied,
                                        const at::Tensor& jitter, const MarchParams& params) {
  CheckOnOneCudaDevice("MarchRaysCuda", {&origins, &dirs, &occupied});
  TORCH_CHECK(
      origins.scalar_type() == at::kFloat && dirs.scalar_type() == at::kFloat && occupied.scalar_type() == at::kBool,
      "MarchRaysCuda: float32 rays and a bool grid expected");
  TORCH_CHECK(occupied.numel() == static_cast<std::int64_t>(params.resolution) * params.resolution * params.resolution,
              "MarchRaysCuda: occupied must be [G, G, G]");
  if (jitter.defined()) {
    CheckOnOneCudaDevice("MarchRaysCuda", {&origins, &jitter});
    TORCH_CHECK(jitter.scalar_type() == at::kFloat && jitter.numel() == origins.size(0), "MarchRaysCuda: jitter [R]");
  }
  const c10::cuda::CUDAGuard guard(origins.device());
  const auto stream = c10::cuda::getCurrentCUDAStream();
  const std::int64_t R = origins.size(0);
  const auto i64 = origins.options().dtype(at::kLong);
  const float* jit = jitter.defined() ? jitter.data_ptr<float>() : nullptr;
  at::Tensor counts = at::empty({R}, i64);
  if (R > 0) {
    MarchCountKernel<<<Blocks(R), kThreads, 0, stream>>>(origins.data_ptr<float>(), dirs.data_ptr<float>(),
                                                         occupied.data_ptr<bool>(), jit,
                                                         counts.data_ptr<std::int64_t>(), R, params);
    C10_CUDA_KERNEL_LAUNCH_CHECK();
  }
  // Exclusive scan: offsets[0] = 0, offsets[r + 1] = samples of rays 0..r.
  at::Tensor offsets = at::zeros({R + 1}, i64);
  if (R > 0) offsets.slice(0, 1).copy_(counts.cumsum(0));
  const std::int64_t S = offsets[R].item<std::int64_t>();  // synchronises: the outputs' size
  at::Tensor t_starts = at::empty({S}, origins.options());
  at::Tensor t_ends = at::empty({S}, origins.options());
  at::Tensor ray_ids = at::empty({S}, i64);
  if (S > 0) {
    MarchFillKernel<<<Blocks(R), kThreads, 0, stream>>>(
        origins.data_ptr<float>(), dirs.data_ptr<float>(), occupied.data_ptr<bool>(), jit,
        offsets.data_ptr<std::int64_t>(), t_starts.data_ptr<float>(), t_ends.data_ptr<float>(),
        ray_ids.data_ptr<std::int64_t>(), R, params);
    C10_CUDA_KERNEL_LAUNCH_CHECK();
  }
  return {offsets, t_starts, t_ends, ray_ids};
}

std::array<at::Tensor, 3> CompositeForwardCuda(const at::Tensor& sigmas, const at::Tensor& rgbs,
                                               const at::Tensor& t_starts, const at::Tensor& t_ends,
                                               const at::Tensor& offsets, float early_stop) {
  CheckOnOneCudaDevice("CompositeForwardCuda", {&sigmas, &rgbs, &t_starts, &t_ends, &offsets});
  TORCH_CHECK(sigmas.scalar_type() == at::kFloat && rgbs.scalar_type() == at::kFloat &&
                  t_starts.scalar_type() == at::kFloat && t_ends.scalar_type() == at::kFloat &&
                  offsets.scalar_type() == at::kLong,
              "CompositeForwardCuda: float32 samples and int64 offsets expected");
  const c10::cuda::CUDAGuard guard(sigmas.device());
  const std::int64_t R = offsets.size(0) - 1;
  at::Tensor rgb = at::zeros({R, 3}, sigmas.options());
  at::Tensor opacity = at::zeros({R}, sigmas.options());
  at::Tensor depth = at::zeros({R}, sigmas.options());
  if (R <= 0) return {rgb, opacity, depth};
  const auto stream = c10::cuda::getCurrentCUDAStream();
  CompositeForwardKernel<<<Blocks(R), kThreads, 0, stream>>>(
      sigmas.data_ptr<float>(), rgbs.data_ptr<float>(), t_starts.data_ptr<float>(), t_ends.data_ptr<float>(),
      offsets.data_ptr<std::int64_t>(), rgb.data_ptr<float>(), opacity.data_ptr<float>(), depth.data_ptr<float>(), R,
      early_stop);
  C10_CUDA_KERNEL_LAUNCH_CHECK();
  return {rgb, opacity, depth};
}

std::array<at::Tensor, 2> CompositeBackwardCuda(const at::Tensor& sigmas, const at::Tensor& rgbs,
                                                const at::Tensor& t_starts, const at::Tensor& t_ends,
                                                const at::Tensor& offsets, const at::Tensor& rgb,
                                                const at::Tensor& opacity, const at::Tensor& depth,
                                                const at::Tensor& grad_rgb, const at::Tensor& grad_opacity,
                                                const at::Tensor& grad_depth, float early_stop) {
  CheckOnOneCudaDevice("CompositeBackwardCuda", {&sigmas, &rgbs, &t_starts, &t_ends, &offsets, &rgb, &opacity, &depth,
                                                 &grad_rgb, &grad_opacity, &grad_depth});
  TORCH_CHECK(grad_rgb.scalar_type() == at::kFloat && grad_opacity.scalar_type() == at::kFloat &&
                  grad_depth.scalar_type() == at::kFloat,
              "CompositeBackwardCuda: float32 gradients expected");
  const c10::cuda::CUDAGuard guard(sigmas.device());
  const std::int64_t R = offsets.size(0) - 1;
  // Samples past a ray's early stop get no gradient: zeros, as in the CPU kernel.
  at::Tensor grad_sigmas = at::zeros_like(sigmas);
  at::Tensor grad_rgbs = at::zeros_like(rgbs);
  if (R <= 0) return {grad_sigmas, grad_rgbs};
  const auto stream = c10::cuda::getCurrentCUDAStream();
  CompositeBackwardKernel<<<Blocks(R), kThreads, 0, stream>>>(
      sigmas.data_ptr<float>(), rgbs.data_ptr<float>(), t_starts.data_ptr<float>(), t_ends.data_ptr<float>(),
      offsets.data_ptr<std::int64_t>(), rgb.data_ptr<float>(), opacity.data_ptr<float>(), depth.data_ptr<float>(),
      grad_rgb.data_ptr<float>(), grad_opacity.data_ptr<float>(), grad_depth.data_ptr<float>(),
      grad_sigmas.data_ptr<float>(), grad_rgbs.data_ptr<float>(), R, early_stop);
  C10_CUDA_KERNEL_LAUNCH_CHECK();
  return {grad_sigmas, grad_rgbs};
}

}  // namespace nerfreg
