#pragma once
// Small instant-ngp snapshots for tests (data, nerf, CLI, bad-input battery), written from the
// documented layout (see ngp_snapshot.h) without using the reader's code. Weights are multiples of
// 1/1024 in [-1, 1], exact in fp16, and returned as floats so a test can build an independent
// reference of the model.
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace nerfreg {

struct TestNgpSnapshotOptions {
  int levels = 4;
  int features = 4;  // levels * features must be a multiple of 16 (no padding)
  int log2_table_size = 10;
  int base_resolution = 4;
  double per_level_scale = 1.5;  // resolutions 4, 6, 9, 14: dense (one of 736 rows) and hashed levels
  int width = 16;                // both MLPs
  int aabb_scale = 2;            // 2 cascades
  int grid_size = 16;            // density grid cells per axis
  unsigned seed = 0;
  double dataset_scale = 0.25;  // stored as nerf.dataset.scale / offset
  std::vector<double> dataset_offset = {0.5, 0.4, 0.6};
};

struct TestNgpSnapshot {
  nlohmann::json json;
  std::vector<float> params;           // density MLP, colour MLP, grid: exactly what the file holds
  std::vector<std::uint8_t> occupied;  // [cascade][z][y][x], 1 where the density grid is 1.0
};

inline std::uint16_t TestHalf(float v) {  // v = k / 1024, |k| <= 1024: exact in fp16
  if (v == 0) return 0;
  const std::uint16_t sign = v < 0 ? 0x8000 : 0;
  int e;
  const float m = std::frexp(std::fabs(v), &e);  // [0.5, 1)
  const std::uint32_t mant = static_cast<std::uint32_t>(std::ldexp(m, 11)) - 1024;
  return sign | static_cast<std::uint16_t>(((e - 1 + 15) << 10) | mant);
}

inline std::uint32_t TestMorton(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  std::uint32_t m = 0;
  for (int b = 0; b < 10; ++b)
    m |= ((x >> b) & 1u) << (3 * b) | ((y >> b) & 1u) << (3 * b + 1) | ((z >> b) & 1u) << (3 * b + 2);
  return m;
}

inline std::int64_t TestNgpGridRows(const TestNgpSnapshotOptions& o) {
  std::int64_t rows = 0;
  for (int l = 0; l < o.levels; ++l) {
    const float scale = std::exp2(l * std::log2(static_cast<float>(o.per_level_scale))) * o.base_resolution - 1.0f;
    const std::int64_t res = static_cast<std::int64_t>(std::ceil(scale)) + 1;
    rows += std::min<std::int64_t>((res * res * res + 7) / 8 * 8, std::int64_t(1) << o.log2_table_size);
  }
  return rows;
}

inline TestNgpSnapshot MakeTestNgpSnapshot(const TestNgpSnapshotOptions& o = {}) {
  using nlohmann::json;
  TestNgpSnapshot s;
  const int w = o.width, enc = o.levels * o.features;
  const std::int64_t n = std::int64_t(w) * enc + std::int64_t(16) * w +  // density: 1 hidden layer, 16 outputs
                         std::int64_t(w) * 32 + std::int64_t(w) * w +
                         16 * w +  // colour: 32 inputs, 2 hidden, 3 -> 16 rows
                         TestNgpGridRows(o) * o.features;
  std::mt19937 rng(o.seed);
  std::uniform_int_distribution<int> k(-1024, 1024);
  s.params.resize(static_cast<std::size_t>(n));
  std::vector<std::uint8_t> bin(static_cast<std::size_t>(2 * n));
  for (std::int64_t i = 0; i < n; ++i) {
    // Network weights scaled down so activations stay in a useful range; grid features full range.
    const bool grid = i >= std::int64_t(w) * enc + 16 * w + 32 * w + w * w + 16 * w;
    s.params[i] = static_cast<float>(k(rng)) / 1024.f / (grid ? 1.f : 4.f);
    const std::uint16_t h = TestHalf(s.params[i]);
    bin[2 * i] = static_cast<std::uint8_t>(h & 0xff);
    bin[2 * i + 1] = static_cast<std::uint8_t>(h >> 8);
  }
  // Density grid: cascade 0 has the box of cells [4, 8)^3 (and cell (1, 2, 3)); cascade 1 a box in its outer shell.
  const int g = o.grid_size, cascades = static_cast<int>(std::log2(o.aabb_scale)) + 1;
  const std::int64_t cells = std::int64_t(g) * g * g;
  std::vector<std::uint8_t> grid(static_cast<std::size_t>(2 * cells * cascades), 0);
  s.occupied.assign(static_cast<std::size_t>(cells * cascades), 0);
  const std::uint16_t one = TestHalf(1.0f);
  for (int c = 0; c < cascades; ++c)
    for (int z = 0; z < g; ++z)
      for (int y = 0; y < g; ++y)
        for (int x = 0; x < g; ++x) {
          const bool on =
              c == 0 ? ((x >= 4 && x < 8 && y >= 4 && y < 8 && z >= 4 && z < 8) || (x == 1 && y == 2 && z == 3))
                     : (x < 2 && y >= g - 3 && z < 3);
          if (!on) continue;
          const std::int64_t m = c * cells + TestMorton(x, y, z);
          grid[2 * m] = one & 0xff;
          grid[2 * m + 1] = one >> 8;
          s.occupied[c * cells + (std::int64_t(z) * g + y) * g + x] = 1;
        }
  const double lo = 0.5 - 0.5 * o.aabb_scale, hi = 0.5 + 0.5 * o.aabb_scale;
  s.json = {
      {"encoding",
       {{"otype", "HashGrid"},
        {"n_levels", o.levels},
        {"n_features_per_level", o.features},
        {"log2_hashmap_size", o.log2_table_size},
        {"base_resolution", o.base_resolution},
        {"per_level_scale", o.per_level_scale}}},
      {"network",
       {{"otype", "FullyFusedMLP"},
        {"activation", "ReLU"},
        {"output_activation", "None"},
        {"n_neurons", w},
        {"n_hidden_layers", 1}}},
      {"dir_encoding",
       {{"otype", "Composite"},
        {"nested", json::array({{{"n_dims_to_encode", 3}, {"otype", "SphericalHarmonics"}, {"degree", 4}},
                                {{"otype", "Identity"}}})}}},
      {"rgb_network",
       {{"otype", "FullyFusedMLP"},
        {"activation", "ReLU"},
        {"output_activation", "None"},
        {"n_neurons", w},
        {"n_hidden_layers", 2}}},
      {"snapshot",
       {{"version", 1},
        {"mode", "nerf"},
        {"n_params", n},
        {"params_type", "__half"},
        {"params_binary", json::binary(bin)},
        {"density_grid_size", g},
        {"density_grid_binary", json::binary(grid)},
        {"aabb", {{"min", {lo, lo, lo}}, {"max", {hi, hi, hi}}}},
        {"nerf",
         {{"aabb_scale", o.aabb_scale},
          {"dataset", {{"scale", o.dataset_scale}, {"offset", o.dataset_offset}, {"aabb_scale", o.aabb_scale}}}}}}}};
  return s;
}

// Bytes of a snapshot: msgpack, or zlib-compressed msgpack (.ingp).
inline std::vector<std::uint8_t> TestNgpSnapshotBytes(const nlohmann::json& j, bool compressed) {
  std::vector<std::uint8_t> raw = nlohmann::json::to_msgpack(j);
  if (!compressed) return raw;
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> out(size);
  if (compress2(out.data(), &size, raw.data(), static_cast<uLong>(raw.size()), 6) != Z_OK)
    throw std::runtime_error("compress2");
  out.resize(size);
  return out;
}

inline void WriteTestNgpSnapshot(const nlohmann::json& j, const std::string& path, bool compressed) {
  const auto bytes = TestNgpSnapshotBytes(j, compressed);
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) throw std::runtime_error("cannot write " + path);
}

}  // namespace nerfreg
