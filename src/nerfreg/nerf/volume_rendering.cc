#include "nerfreg/nerf/volume_rendering.h"

#include <cmath>
#include <random>
#include <stdexcept>

#ifdef NERFREG_WITH_CUDA
#include "nerfreg/nerf/volume_rendering_cuda.h"
#endif

namespace nerfreg {

void MarchOptions::Check() const {
  if (!(step_size > 0) || near < 0 || max_samples_per_ray < 1)
    throw std::invalid_argument("MarchOptions: out of range");
}

RaySamples MarchRays(const torch::Tensor& origins, const torch::Tensor& dirs, const OccupancyGrid& grid,
                     const MarchOptions& o, torch::Generator gen) {
  o.Check();
  TORCH_CHECK(origins.dim() == 2 && origins.size(1) == 3 && dirs.sizes() == origins.sizes(),
              "MarchRays: [R, 3] expected");
  const std::int64_t R = origins.size(0);
  const int G = grid.resolution();
  float mn[3], mx[3], inv_cell[3];
  for (int d = 0; d < 3; ++d) {
    mn[d] = static_cast<float>(grid.aabb_min()[d]);
    mx[d] = static_cast<float>(grid.aabb_max()[d]);
    inv_cell[d] = G / (mx[d] - mn[d]);
  }
  // The start offsets are drawn on the CPU from `gen` whatever the rays' device: a CUDA march with
  // perturb then takes the same samples as the CPU one for the same generator state.
  const auto offsets_from_rand = o.perturb ? torch::rand({R}, gen) : torch::full({R}, 0.5f);  // [R] in steps
#ifdef NERFREG_WITH_CUDA
  if (origins.is_cuda()) {
    MarchParams p;
    for (int d = 0; d < 3; ++d) {
      p.aabb_min[d] = mn[d];
      p.aabb_max[d] = mx[d];
      p.inv_cell[d] = inv_cell[d];
    }
    p.resolution = G;
    p.near = static_cast<float>(o.near);
    p.step = static_cast<float>(o.step_size);
    p.half_step = 0.5f * p.step;
    p.max_samples = o.max_samples_per_ray;
    const torch::Device device = origins.device();
    const auto jitter = o.perturb ? offsets_from_rand.to(device) : torch::Tensor();
    const auto out =
        MarchRaysCuda(origins.to(torch::kFloat32).contiguous(), dirs.to(device, torch::kFloat32).contiguous(),
                      grid.occupied().to(device).contiguous(), jitter, p);
    return {out[0], out[1], out[2], out[3]};
  }
#endif
  const auto ori = origins.to(torch::kFloat32).contiguous().cpu(), dir = dirs.to(torch::kFloat32).contiguous().cpu();
  const auto occ = grid.occupied().contiguous().cpu();  // [G, G, G] bool
  const float* po = ori.data_ptr<float>();
  const float* pd = dir.data_ptr<float>();
  const bool* pocc = occ.data_ptr<bool>();
  const float* jit = offsets_from_rand.data_ptr<float>();
  const float step = static_cast<float>(o.step_size);

  // Two passes: count, then fill, so the output is allocated once.
  std::vector<std::int64_t> counts(R + 1, 0);
  auto march = [&](std::int64_t r, auto&& emit) {
    const float* oo = po + 3 * r;
    const float* dd = pd + 3 * r;
    float t0 = static_cast<float>(o.near), t1 = 1e30f;
    for (int d = 0; d < 3; ++d) {  // slab test against the AABB
      const float inv = 1.f / (std::abs(dd[d]) > 1e-12f ? dd[d] : 1e-12f);
      float ta = (mn[d] - oo[d]) * inv, tb = (mx[d] - oo[d]) * inv;
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (!(t1 > t0)) return;
    int n = 0;
    for (float t = t0 + jit[r] * step; t < t1 && n < o.max_samples_per_ray; t += step) {
      int c[3];
      bool in = true;
      for (int d = 0; d < 3; ++d) {
        c[d] = static_cast<int>((oo[d] + t * dd[d] - mn[d]) * inv_cell[d]);
        in = in && c[d] >= 0 && c[d] < G;
      }
      if (!in || !pocc[(std::int64_t(c[0]) * G + c[1]) * G + c[2]]) continue;
      emit(t - 0.5f * step, t + 0.5f * step);
      ++n;
    }
  };
#pragma omp parallel for schedule(dynamic, 64)
  for (std::int64_t r = 0; r < R; ++r) {
    std::int64_t n = 0;
    march(r, [&](float, float) { ++n; });
    counts[r + 1] = n;
  }
  for (std::int64_t r = 0; r < R; ++r) counts[r + 1] += counts[r];
  const std::int64_t S = counts[R];
  RaySamples s;
  s.offsets = torch::from_blob(counts.data(), {R + 1}, torch::kInt64).clone();
  s.t_starts = torch::empty({S});
  s.t_ends = torch::empty({S});
  s.ray_ids = torch::empty({S}, torch::kInt64);
  float* ts = s.t_starts.data_ptr<float>();
  float* te = s.t_ends.data_ptr<float>();
  std::int64_t* ids = s.ray_ids.data_ptr<std::int64_t>();
#pragma omp parallel for schedule(dynamic, 64)
  for (std::int64_t r = 0; r < R; ++r) {
    std::int64_t k = counts[r];
    march(r, [&](float a, float b) {
      ts[k] = a;
      te[k] = b;
      ids[k] = r;
      ++k;
    });
  }
  return s;
}

namespace {

class CompositeFunction : public torch::autograd::Function<CompositeFunction> {
 public:
  static torch::autograd::tensor_list forward(torch::autograd::AutogradContext* ctx, torch::Tensor sigmas,
                                              torch::Tensor rgbs, torch::Tensor t_starts, torch::Tensor t_ends,
                                              torch::Tensor offsets, double early_stop) {
    ctx->saved_data["stop"] = early_stop;
#ifdef NERFREG_WITH_CUDA
    if (sigmas.is_cuda()) {
      const auto out = CompositeForwardCuda(sigmas, rgbs, t_starts, t_ends, offsets, static_cast<float>(early_stop));
      ctx->save_for_backward({sigmas, rgbs, t_starts, t_ends, offsets, out[0], out[1], out[2]});
      return {out[0], out[1], out[2]};
    }
#endif
    const std::int64_t R = offsets.size(0) - 1;
    auto color = torch::zeros({R, 3}), opacity = torch::zeros({R}), depth = torch::zeros({R});
    const float* sg = sigmas.data_ptr<float>();
    const float* cl = rgbs.data_ptr<float>();
    const float* a = t_starts.data_ptr<float>();
    const float* b = t_ends.data_ptr<float>();
    const std::int64_t* off = offsets.data_ptr<std::int64_t>();
    float* oc = color.data_ptr<float>();
    float* oo = opacity.data_ptr<float>();
    float* od = depth.data_ptr<float>();
    const float stop = static_cast<float>(early_stop);
#pragma omp parallel for schedule(dynamic, 64)
    for (std::int64_t r = 0; r < R; ++r) {
      float T = 1.f, c0 = 0, c1 = 0, c2 = 0, acc = 0, dep = 0;
      for (std::int64_t i = off[r]; i < off[r + 1]; ++i) {
        const float delta = b[i] - a[i];
        const float alpha = 1.f - std::exp(-sg[i] * delta);
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
    ctx->save_for_backward({sigmas, rgbs, t_starts, t_ends, offsets, color, opacity, depth});
    return {color, opacity, depth};
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto &sigmas = saved[0], &rgbs = saved[1], &t_starts = saved[2], &t_ends = saved[3], &offsets = saved[4];
    const auto &color = saved[5], &opacity = saved[6], &depth = saved[7];
    const float stop = static_cast<float>(ctx->saved_data["stop"].toDouble());
    auto zeros_if_undef = [](const torch::Tensor& g, const torch::Tensor& like) {
      return g.defined() ? g.contiguous() : torch::zeros_like(like);
    };
    const auto gc = zeros_if_undef(grads[0], color), go = zeros_if_undef(grads[1], opacity),
               gd = zeros_if_undef(grads[2], depth);
#ifdef NERFREG_WITH_CUDA
    if (sigmas.is_cuda()) {
      const auto g =
          CompositeBackwardCuda(sigmas, rgbs, t_starts, t_ends, offsets, color, opacity, depth, gc, go, gd, stop);
      return {g[0], g[1], torch::Tensor(), torch::Tensor(), torch::Tensor(), torch::Tensor()};
    }
#endif
    const std::int64_t R = offsets.size(0) - 1;
    auto gsig = torch::zeros_like(sigmas), grgb = torch::zeros_like(rgbs);
    const float* sg = sigmas.data_ptr<float>();
    const float* cl = rgbs.data_ptr<float>();
    const float* a = t_starts.data_ptr<float>();
    const float* b = t_ends.data_ptr<float>();
    const std::int64_t* off = offsets.data_ptr<std::int64_t>();
    const float* C = color.data_ptr<float>();
    const float* A = opacity.data_ptr<float>();
    const float* D = depth.data_ptr<float>();
    const float* pgc = gc.data_ptr<float>();
    const float* pgo = go.data_ptr<float>();
    const float* pgd = gd.data_ptr<float>();
    float* ps = gsig.data_ptr<float>();
    float* pr = grgb.data_ptr<float>();
#pragma omp parallel for schedule(dynamic, 64)
    for (std::int64_t r = 0; r < R; ++r) {
      float T = 1.f, c[3] = {0, 0, 0}, acc = 0, dep = 0;
      for (std::int64_t i = off[r]; i < off[r + 1]; ++i) {
        const float delta = b[i] - a[i];
        const float alpha = 1.f - std::exp(-sg[i] * delta);
        const float w = T * alpha;
        const float t_mid = 0.5f * (a[i] + b[i]);
        for (int k = 0; k < 3; ++k) {
          c[k] += w * cl[3 * i + k];
          pr[3 * i + k] = w * pgc[3 * r + k];
        }
        acc += w;
        dep += w * t_mid;
        const float T_next = T * (1.f - alpha);
        float g = 0;
        for (int k = 0; k < 3; ++k) g += pgc[3 * r + k] * (T_next * cl[3 * i + k] - (C[3 * r + k] - c[k]));
        g += pgo[r] * (T_next - (A[r] - acc));
        g += pgd[r] * (T_next * t_mid - (D[r] - dep));
        ps[i] = delta * g;
        T = T_next;
        if (T < stop) break;
      }
    }
    return {gsig, grgb, torch::Tensor(), torch::Tensor(), torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

CompositeResult Composite(const torch::Tensor& sigmas, const torch::Tensor& rgbs, const torch::Tensor& t_starts,
                          const torch::Tensor& t_ends, const torch::Tensor& offsets, double early_stop) {
  TORCH_CHECK(sigmas.dim() == 1 && rgbs.dim() == 2 && rgbs.size(1) == 3 && rgbs.size(0) == sigmas.size(0),
              "Composite: sigmas [S], rgbs [S, 3] expected");
  TORCH_CHECK(t_starts.sizes() == sigmas.sizes() && t_ends.sizes() == sigmas.sizes() && offsets.dim() == 1,
              "Composite: t_starts, t_ends [S], offsets [R + 1] expected");
  if (!CompositeHasKernel(sigmas.device()))
    return CompositeReference(sigmas, rgbs, t_starts, t_ends, offsets, early_stop);
  const torch::Device device = sigmas.device();
  const auto out = CompositeFunction::apply(sigmas.contiguous(), rgbs.to(device).contiguous(),
                                            t_starts.to(device).contiguous(), t_ends.to(device).contiguous(),
                                            offsets.to(device, torch::kInt64).contiguous(), early_stop);
  return {out[0], out[1], out[2]};
}

bool CompositeHasKernel(const torch::Device& device) {
#ifdef NERFREG_WITH_CUDA
  if (device.is_cuda()) return true;
#endif
  return device.is_cpu();
}

CompositeResult CompositeReference(const torch::Tensor& sigmas, const torch::Tensor& rgbs,
                                   const torch::Tensor& t_starts, const torch::Tensor& t_ends,
                                   const torch::Tensor& offsets, double early_stop) {
  const auto off = offsets.to(torch::kInt64).cpu();
  const std::int64_t R = off.size(0) - 1;
  std::vector<torch::Tensor> colors, opac, depths;
  for (std::int64_t r = 0; r < R; ++r) {
    const std::int64_t s0 = off[r].item<std::int64_t>(), s1 = off[r + 1].item<std::int64_t>();
    if (s1 == s0) {
      colors.push_back(torch::zeros({3}, rgbs.options()));
      opac.push_back(torch::zeros({}, sigmas.options()));
      depths.push_back(torch::zeros({}, sigmas.options()));
      continue;
    }
    const auto sg = sigmas.slice(0, s0, s1), cl = rgbs.slice(0, s0, s1);
    const auto a = t_starts.slice(0, s0, s1), b = t_ends.slice(0, s0, s1);
    const auto alpha = 1 - torch::exp(-sg * (b - a));
    const auto trans = torch::cat({torch::ones({1}, alpha.options()), torch::cumprod(1 - alpha, 0).slice(0, 0, -1)});
    // Early termination: samples after T drops below the threshold (after the one that drops it).
    const auto keep = torch::cat({torch::ones({1}, alpha.options()),
                                  (torch::cumprod(1 - alpha, 0) >= early_stop).to(alpha.dtype()).slice(0, 0, -1)});
    const auto keep_mask = torch::cumprod(keep, 0).detach();
    const auto w = trans * alpha * keep_mask;
    colors.push_back((w.unsqueeze(1) * cl).sum(0));
    opac.push_back(w.sum());
    depths.push_back((w * 0.5 * (a + b)).sum());
  }
  return {torch::stack(colors), torch::stack(opac), torch::stack(depths)};
}

}  // namespace nerfreg
