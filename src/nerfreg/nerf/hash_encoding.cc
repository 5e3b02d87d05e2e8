#include "nerfreg/nerf/hash_encoding.h"

#include <cmath>
#include <stdexcept>
#include <vector>
#include <algorithm>

#include "nerfreg/data/ngp_snapshot.h"
#ifdef NERFREG_WITH_CUDA
#include "nerfreg/nerf/hash_encoding_cuda.h"
#endif

namespace nerfreg {

void HashEncodingOptions::Check() const {
  if (levels < 1 || levels > 32 || features < 1 || features > 8 || log2_table_size < 4 || log2_table_size > 24 ||
      base_resolution < 2 || !(per_level_scale >= 1.0) || (grid_rule != "nerfreg" && grid_rule != "instant-ngp")) {
    throw std::invalid_argument("HashEncodingOptions: out of range");
  }
}

namespace {
NgpGridEncoding NgpEncoding(const HashEncodingOptions& o) {
  NgpGridEncoding e;
  e.levels = o.levels;
  e.features = o.features;
  e.log2_table_size = o.log2_table_size;
  e.base_resolution = o.base_resolution;
  e.per_level_scale = o.per_level_scale;
  return e;
}
}  // namespace

int LevelResolution(const HashEncodingOptions& o, int level) {
  if (o.grid_rule == "instant-ngp") return static_cast<int>(NgpGridLevels(NgpEncoding(o))[level].resolution);
  return static_cast<int>(std::floor(o.base_resolution * std::pow(o.per_level_scale, level)));
}

namespace {

constexpr std::uint32_t kPrime1 = 2654435761u, kPrime2 = 805459861u;

struct LevelInfo {
  int resolution;
  bool dense;
  float scale;           // position scale: p * scale + 0.5, as instant-NGP's grid_scale
  std::uint32_t stride;  // dense index x + y * stride + z * stride^2
  bool wrap;             // dense index mod rows (instant-ngp), else & (T - 1)
  std::uint32_t rows;    // rows of the level's table in use
};

std::vector<LevelInfo> Levels(const HashEncodingOptions& o) {
  std::vector<LevelInfo> out;
  if (o.grid_rule == "instant-ngp") {
    for (const NgpGridLevel& n : NgpGridLevels(NgpEncoding(o))) {
      out.push_back({static_cast<int>(n.resolution), n.dense, n.scale, n.resolution, true, n.entries});
    }
    return out;
  }
  for (int l = 0; l < o.levels; ++l) {
    LevelInfo li;
    li.resolution = LevelResolution(o, l);
    li.scale = static_cast<float>(li.resolution - 1);
    const double verts = std::pow(double(li.resolution + 1), 3);
    li.dense = verts <= double(o.TableSize());
    li.stride = static_cast<std::uint32_t>(li.resolution + 1);
    li.wrap = false;
    li.rows = static_cast<std::uint32_t>(o.TableSize());
    out.push_back(li);
  }
  return out;
}

inline std::uint32_t GridIndex(const LevelInfo& li, std::uint32_t x, std::uint32_t y, std::uint32_t z,
                               std::uint32_t mask) {
  if (li.dense) {
    const std::uint32_t i = x + y * li.stride + z * li.stride * li.stride;
    return li.wrap ? i % li.rows : i & mask;
  }
  return (x ^ (y * kPrime1) ^ (z * kPrime2)) & mask;
}

// The 8 corners of one point at one level: table indices and trilinear weights. pos >= 0.5, so
// truncation is floor (std::floor is a libm call on baseline x86-64).
inline void Corners(const LevelInfo& li, const float* p, std::uint32_t mask, std::uint32_t idx[8], float w[8]) {
  float frac[3];
  std::uint32_t base[3];
  for (int d = 0; d < 3; ++d) {
    const float pos = std::min(std::max(p[d], 0.f), 1.f) * li.scale + 0.5f;
    base[d] = static_cast<std::uint32_t>(pos);
    frac[d] = pos - static_cast<float>(base[d]);
  }
  for (int c = 0; c < 8; ++c) {
    const std::uint32_t dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    w[c] = (dx ? frac[0] : 1 - frac[0]) * (dy ? frac[1] : 1 - frac[1]) * (dz ? frac[2] : 1 - frac[2]);
    idx[c] = GridIndex(li, base[0] + dx, base[1] + dy, base[2] + dz, mask);
  }
}

#ifdef NERFREG_WITH_CUDA
HashGridParams CudaGrid(const HashEncodingOptions& o) {
  HashGridParams g;
  const auto levels = Levels(o);
  g.levels = o.levels;
  g.features = o.features;
  g.mask = static_cast<std::uint32_t>(o.TableSize() - 1);
  g.table_size = o.TableSize();
  for (int l = 0; l < o.levels; ++l) {
    const LevelInfo& li = levels[l];
    g.level[l] = {li.dense ? 1 : 0, li.scale, li.stride, li.wrap ? 1 : 0, li.rows};
  }
  return g;
}
#endif

// Points are processed in groups: every corner of the group is located and its cache line
// prefetched before any is read, so the fine levels' misses (tables beyond L2) overlap instead of
// queueing one level at a time.
constexpr int kGroup = 8;

class HashEncodingFunction : public torch::autograd::Function<HashEncodingFunction> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, torch::Tensor positions, torch::Tensor table,
                               const HashEncodingOptions& o) {
    ctx->save_for_backward({positions});
    ctx->saved_data["levels"] = static_cast<std::int64_t>(o.levels);
    ctx->saved_data["features"] = static_cast<std::int64_t>(o.features);
    ctx->saved_data["log2"] = static_cast<std::int64_t>(o.log2_table_size);
    ctx->saved_data["base"] = static_cast<std::int64_t>(o.base_resolution);
    ctx->saved_data["scale"] = o.per_level_scale;
    ctx->saved_data["rule"] = o.grid_rule;
#ifdef NERFREG_WITH_CUDA
    if (positions.is_cuda()) return HashEncodeForwardCuda(positions, table, CudaGrid(o));
#endif
    const auto levels = Levels(o);
    const std::int64_t n = positions.size(0);
    const int L = o.levels, F = o.features;
    const std::uint32_t mask = static_cast<std::uint32_t>(o.TableSize() - 1);
    auto out = torch::empty({n, L * F}, positions.options());
    const float* pos = positions.data_ptr<float>();
    const float* tab = table.data_ptr<float>();
    float* dst = out.data_ptr<float>();
    const std::int64_t level_stride = o.TableSize() * F;
#pragma omp parallel
    {
      std::vector<std::uint32_t> idx(std::size_t(kGroup) * L * 8);
      std::vector<float> w(std::size_t(kGroup) * L * 8);
#pragma omp for schedule(static)
      for (std::int64_t i0 = 0; i0 < n; i0 += kGroup) {
        const int g_end = static_cast<int>(std::min<std::int64_t>(kGroup, n - i0));
        for (int g = 0; g < g_end; ++g) {
          for (int l = 0; l < L; ++l) {
            std::uint32_t* id = &idx[(g * L + l) * 8];
            Corners(levels[l], pos + 3 * (i0 + g), mask, id, &w[(g * L + l) * 8]);
            const float* t = tab + l * level_stride;
            for (int c = 0; c < 8; c += 2) __builtin_prefetch(t + std::size_t(id[c]) * F);
          }
        }
        for (int g = 0; g < g_end; ++g) {
          float* out_row = dst + (i0 + g) * L * F;
          for (int l = 0; l < L; ++l) {
            const std::uint32_t* id = &idx[(g * L + l) * 8];
            const float* wc = &w[(g * L + l) * 8];
            const float* t = tab + l * level_stride;
            for (int f = 0; f < F; ++f) {
              float acc = 0;
              for (int c = 0; c < 8; ++c) acc += wc[c] * t[std::size_t(id[c]) * F + f];
              out_row[l * F + f] = acc;
            }
          }
        }
      }
    }
    return out;
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grads) {
    HashEncodingOptions o;
    o.levels = static_cast<int>(ctx->saved_data["levels"].toInt());
    o.features = static_cast<int>(ctx->saved_data["features"].toInt());
    o.log2_table_size = static_cast<int>(ctx->saved_data["log2"].toInt());
    o.base_resolution = static_cast<int>(ctx->saved_data["base"].toInt());
    o.per_level_scale = ctx->saved_data["scale"].toDouble();
    o.grid_rule = ctx->saved_data["rule"].toStringRef();
    const auto positions = ctx->get_saved_variables()[0];
    const auto grad_out = grads[0].contiguous();
#ifdef NERFREG_WITH_CUDA
    if (positions.is_cuda())
      return {torch::Tensor(), HashEncodeBackwardCuda(positions, grad_out, CudaGrid(o)), torch::Tensor()};
#endif
    const auto levels = Levels(o);
    const std::int64_t n = positions.size(0);
    const int L = o.levels, F = o.features;
    const std::uint32_t mask = static_cast<std::uint32_t>(o.TableSize() - 1);
    auto grad_table = torch::zeros({L, o.TableSize(), F}, grad_out.options());
    const float* pos = positions.data_ptr<float>();
    const float* g_out = grad_out.data_ptr<float>();
    float* gt = grad_table.data_ptr<float>();
    const std::int64_t level_stride = o.TableSize() * F;
    // One level per thread: scatters into a level's slice never race.
#pragma omp parallel for schedule(dynamic, 1)
    for (int l = 0; l < L; ++l) {
      std::uint32_t idx[kGroup][8];
      float w[kGroup][8];
      float* t = gt + l * level_stride;
      for (std::int64_t i0 = 0; i0 < n; i0 += kGroup) {
        const int g_end = static_cast<int>(std::min<std::int64_t>(kGroup, n - i0));
        for (int g = 0; g < g_end; ++g) {
          Corners(levels[l], pos + 3 * (i0 + g), mask, idx[g], w[g]);
          for (int c = 0; c < 8; c += 2) __builtin_prefetch(t + std::size_t(idx[g][c]) * F, 1);
        }
        for (int g = 0; g < g_end; ++g) {
          const float* gi = g_out + (i0 + g) * L * F + l * F;
          for (int c = 0; c < 8; ++c)
            for (int f = 0; f < F; ++f) t[std::size_t(idx[g][c]) * F + f] += w[g][c] * gi[f];
        }
      }
    }
    return {torch::Tensor(), grad_table, torch::Tensor()};
  }
};

}  // namespace

torch::Tensor HashEncode(const torch::Tensor& positions, const torch::Tensor& table, const HashEncodingOptions& o) {
  o.Check();
  TORCH_CHECK(positions.dim() == 2 && positions.size(1) == 3, "HashEncode: positions must be [N, 3]");
  TORCH_CHECK(positions.scalar_type() == torch::kFloat32 && table.scalar_type() == torch::kFloat32,
              "HashEncode: float32 expected");
  TORCH_CHECK(
      table.dim() == 3 && table.size(0) == o.levels && table.size(1) == o.TableSize() && table.size(2) == o.features,
      "HashEncode: table must be [L, T, F]");
  TORCH_CHECK(positions.device() == table.device(), "HashEncode: positions and table must be on one device");
  if (HashEncodeHasKernel(positions.device())) return HashEncodingFunction::apply(positions.contiguous(), table, o);
  return HashEncodeReference(positions, table, o);
}

bool HashEncodeHasKernel(const torch::Device& device) {
#ifdef NERFREG_WITH_CUDA
  if (device.is_cuda()) return true;
#endif
  return device.is_cpu();
}

torch::Tensor HashEncodeReference(const torch::Tensor& positions, const torch::Tensor& table,
                                  const HashEncodingOptions& o) {
  o.Check();
  const auto levels = Levels(o);
  const std::int64_t mask = o.TableSize() - 1;
  std::vector<torch::Tensor> outs;
  for (int l = 0; l < o.levels; ++l) {
    const auto& li = levels[l];
    const auto pos = positions.clamp(0, 1) * li.scale + 0.5;
    const auto fl = pos.floor();
    const auto frac = pos - fl;
    const auto base = fl.to(torch::kInt64);
    torch::Tensor acc;
    for (int c = 0; c < 8; ++c) {
      const std::int64_t dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
      const auto x = base.select(1, 0) + dx, y = base.select(1, 1) + dy, z = base.select(1, 2) + dz;
      torch::Tensor index;
      if (li.dense) {
        const std::int64_t s = li.stride;
        index = li.wrap ? (x + y * s + z * s * s).remainder(std::int64_t(li.rows))
                        : (x + y * s + z * s * s).bitwise_and(mask);
      } else {
        // uint32 arithmetic emulated in int64: multiply, then keep the low 32 bits.
        const std::int64_t low32 = 0xffffffffLL;
        index = x.bitwise_xor((y * static_cast<std::int64_t>(kPrime1)).bitwise_and(low32))
                    .bitwise_xor((z * static_cast<std::int64_t>(kPrime2)).bitwise_and(low32))
                    .bitwise_and(mask);
      }
      const auto w = (dx ? frac.select(1, 0) : 1 - frac.select(1, 0)) *
                     (dy ? frac.select(1, 1) : 1 - frac.select(1, 1)) *
                     (dz ? frac.select(1, 2) : 1 - frac.select(1, 2));
      const auto values = table[l].index_select(0, index);  // [N, F]
      const auto term = values * w.unsqueeze(1);
      acc = c == 0 ? term : acc + term;
    }
    outs.push_back(acc);
  }
  return torch::cat(outs, 1);
}

torch::Tensor InitHashTable(const HashEncodingOptions& o, torch::Generator generator) {
  o.Check();
  return torch::rand({o.levels, o.TableSize(), o.features}, generator, torch::kFloat32) * 2e-4 - 1e-4;
}

}  // namespace nerfreg
