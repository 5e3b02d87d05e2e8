#pragma once
// instant-ngp snapshots (`.msgpack`, and `.ingp` = the same bytes compressed: instant-ngp writes
// them through zstr, i.e. gzip; zlib streams are read too), read into
// plain structs with every size checked against the bytes present before anything is allocated.
// Torch-free, so the sanitizer build fuzzes it (fuzz/ngp_snapshot_fuzz.cc).
//
// The facts this reader relies on (instant-ngp / tiny-cuda-nn, 2022-2024):
//  - The file is nlohmann-json msgpack: the training config (`encoding`, `network`,
//    `dir_encoding`, `rgb_network`) and `snapshot` {n_params, params_type ("__half" | "float"),
//    params_binary, density_grid_size, density_grid_binary (fp16), nerf.aabb_scale, aabb,
//    nerf.dataset.{scale, offset}, version}.
//  - params_binary = density MLP, then colour MLP, then the position hash grid (then the
//    direction encoding, which has no parameters). A FullyFusedMLP stores its matrices one after
//    another, each row-major [outputs, inputs]: [width, in], (hidden-1) x [width, width],
//    [round16(outputs), width]. Its input is the encoding padded to a multiple of 16 (the grid
//    pads with zeros).
//  - Grid level l: scale_l = 2^(l log2 s) * base - 1 (float), resolution_l = ceil(scale_l) + 1,
//    entries_l = min(round8(resolution_l^3), 2^log2T), features interleaved per entry.
//  - The density grid: density_grid_size^3 cells (128) per cascade, Morton order (x in the lowest
//    bit); cascade k covers the cube of side 2^k centred at (0.5, 0.5, 0.5) of ngp's unit space.
//    Values are optical thickness (density * step); a cell is occupied above min(0.01, mean).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace nerfreg {

struct NgpGridEncoding {
  int levels = 16;
  int features = 2;          // F per level
  int log2_table_size = 19;  // T = 2^log2_table_size entries at most per level
  int base_resolution = 16;
  double per_level_scale = 0;  // as stored, or recomputed from aabb_scale when absent
  std::string interpolation = "Linear";
};

// One grid level in tiny-cuda-nn's layout.
struct NgpGridLevel {
  float scale;               // position scale: pos = x * scale + 0.5
  std::uint32_t resolution;  // vertices per axis
  std::uint32_t entries;     // table rows of this level (the modulus of its index)
  bool dense;                // indexed x + y*res + z*res^2, else hashed
  std::int64_t offset;       // first row of the level in the concatenated table
};
std::vector<NgpGridLevel> NgpGridLevels(const NgpGridEncoding& encoding);

struct NgpMlp {
  std::string otype = "FullyFusedMLP";
  int width = 64;          // n_neurons
  int hidden_layers = 1;   // n_hidden_layers
  int inputs = 0;          // padded input width
  int outputs = 0;         // outputs used (density: 16, colour: 3)
  int padded_outputs = 0;  // round16(outputs): rows of the last matrix
  std::int64_t ParamCount() const;
};

struct NgpSnapshot {
  NgpGridEncoding encoding;
  NgpMlp density_network, rgb_network;
  int sh_degree = 4;  // direction encoding: spherical harmonics of this degree (degree^2 outputs)
  // All parameters as float32, in the file's order (density MLP, colour MLP, grid).
  std::vector<float> params;
  std::int64_t density_params_offset = 0, rgb_params_offset = 0, grid_params_offset = 0;
  // Density grid decoded from Morton order: [cascade][z][y][x] (x fastest); empty when absent.
  int density_grid_size = 0;
  int density_cascades = 0;
  std::vector<float> density_grid;
  // Scene box in ngp's unit space, and the transforms.json -> ngp map x_ngp = cycle(scale x + offset).
  int aabb_scale = 1;
  std::array<double, 3> aabb_min{0, 0, 0}, aabb_max{1, 1, 1};
  bool has_dataset_transform = false;  // scale / offset were stored in the snapshot
  double scale = 0.33;
  std::array<double, 3> offset{0.5, 0.5, 0.5};
  std::string density_activation = "Exponential";  // instant-ngp's only trained choice for NeRF
};

struct NgpReadOptions {
  // Refuse a compressed snapshot that inflates beyond this (a zip bomb is an error, not an OOM).
  std::int64_t max_inflated_bytes = std::int64_t(1) << 31;
  void Check() const;
};

// Reads a .msgpack or .ingp (compression detected from the bytes, not the name). Throws
// InputError("FILE: FIELD: expected ...") on anything malformed or unsupported.
NgpSnapshot ReadNgpSnapshot(const std::string& path, const NgpReadOptions& options = {});
NgpSnapshot ParseNgpSnapshot(const std::vector<std::uint8_t>& bytes, const std::string& source,
                             const NgpReadOptions& options = {});

// IEEE half -> float (subnormals, inf and NaN included), and the inverse (round to nearest even)
// for writing test snapshots.
float HalfToFloat(std::uint16_t h);
std::uint16_t FloatToHalf(float f);
// tiny-cuda-nn's 3D Morton code of a cell (10 bits per axis).
std::uint32_t Morton3D(std::uint32_t x, std::uint32_t y, std::uint32_t z);

}  // namespace nerfreg
