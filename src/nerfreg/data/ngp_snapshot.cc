#include "nerfreg/data/ngp_snapshot.h"

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

namespace {

// The deepest nesting of arrays and maps in a msgpack document, counted without recursion and
// stopping once it passes `limit` (nlohmann's msgpack reader recurses per level, so 3 MB of 0x91
// bytes, a 3 KB .ingp, overflowed the stack). Truncated input ends the count; the reader then
// reports it.
int MsgpackDepthUpTo(const std::vector<std::uint8_t>& b, int limit) {
  std::vector<std::uint64_t> remaining;  // items left in each open container
  size_t p = 0;
  int deepest = 0;
  auto be = [&](size_t at, int n) {
    std::uint64_t v = 0;
    for (int k = 0; k < n; ++k) v = v << 8 | b[at + k];
    return v;
  };
  auto skip = [&](std::uint64_t n) {
    if (n > b.size() - p) return false;
    p += static_cast<size_t>(n);
    return true;
  };
  while (p < b.size()) {
    const std::uint8_t t = b[p++];
    std::uint64_t children = 0;
    bool ok = true;
    if (t <= 0x7f || t >= 0xe0 || t == 0xc0 || t == 0xc2 || t == 0xc3) {
    } else if (t <= 0x8f) {  // fixmap: a key and a value per entry
      children = 2ull * (t & 0x0f);
      if (children) goto open;
    } else if (t <= 0x9f) {
      children = t & 0x0f;
      if (children) goto open;
    } else if (t <= 0xbf) {
      ok = skip(t & 0x1f);
    } else {
      static const int kFixed[] = {/*c0*/ 0,        0,   0,   0,
                                   /*c4 bin*/ -1,   -2,  -4,
                                   /*c7 ext*/ -11,  -12, -14,
                                   /*ca*/ 4,        8,
                                   /*cc*/ 1,        2,   4,   8,
                                   /*d0*/ 1,        2,   4,   8,
                                   /*d4 fixext*/ 2, 3,   5,   9, 17,
                                   /*d9 str*/ -1,   -2,  -4};
      if (t >= 0xdc) {  // array16/32, map16/32
        const int n = (t == 0xdc || t == 0xde) ? 2 : 4;
        if (b.size() - p < static_cast<size_t>(n)) break;
        children = be(p, n) * ((t >= 0xde) ? 2 : 1);
        p += n;
        if (children) goto open;
      } else {
        const int f = kFixed[t - 0xc0];
        if (f >= 0) {
          ok = skip(static_cast<std::uint64_t>(f));
        } else {
          const int len_bytes = (-f) % 10, extra = (-f) / 10;  // ext: one type byte after the length
          if (b.size() - p < static_cast<size_t>(len_bytes)) break;
          const std::uint64_t len = be(p, len_bytes);
          p += len_bytes;
          ok = skip(len + static_cast<std::uint64_t>(extra));
        }
      }
    }
    if (!ok) break;
    // One item done: close every container it completes.
    while (!remaining.empty() && --remaining.back() == 0) remaining.pop_back();
    continue;
  open:
    remaining.push_back(children);
    deepest = std::max(deepest, static_cast<int>(remaining.size()));
    if (deepest > limit) return deepest;
  }
  return deepest;
}

std::int64_t RoundUp(std::int64_t v, std::int64_t m) { return (v + m - 1) / m * m; }

// An integer field within [lo, hi]; huge or negative claims are errors before any use.
std::int64_t IntIn(const JsonField& f, std::int64_t lo, std::int64_t hi) {
  const Json& j = f.json();
  const std::string range = "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (!j.is_number_integer()) f.Fail(range);
  if (j.is_number_unsigned()) {
    const auto u = j.get<std::uint64_t>();
    // Both bounds: msgpack stores non-negative integers unsigned, so 0 arrives here (found by
    // fuzzing: base_resolution 0 passed as "in [1, 65536]").
    if (u > static_cast<std::uint64_t>(hi) || static_cast<std::int64_t>(u) < lo) f.Fail(range);
    return static_cast<std::int64_t>(u);
  }
  const auto v = j.get<std::int64_t>();
  if (v < lo || v > hi) f.Fail(range);
  return v;
}
std::int64_t IntInOr(const JsonField& f, const std::string& key, std::int64_t lo, std::int64_t hi,
                     std::int64_t fallback) {
  return f.Has(key) ? IntIn(f[key], lo, hi) : fallback;
}

std::string Lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

const Json::binary_t& Binary(const JsonField& f) {
  if (!f.json().is_binary()) f.Fail("msgpack binary data");
  return f.json().get_binary();
}

bool LooksCompressed(const std::vector<std::uint8_t>& b) {
  if (b.size() < 2) return false;
  if (b[0] == 0x1f && b[1] == 0x8b) return true;                                    // gzip
  return (b[0] & 0x0f) == 8 && (b[0] >> 4) <= 7 && ((b[0] << 8) | b[1]) % 31 == 0;  // zlib
}

std::vector<std::uint8_t> Inflate(const std::vector<std::uint8_t>& in, const std::string& source,
                                  std::int64_t max_bytes) {
  z_stream zs;
  std::memset(&zs, 0, sizeof(zs));
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw std::runtime_error("inflateInit2 failed");  // zlib or gzip
  zs.next_in = const_cast<Bytef*>(in.data());
  zs.avail_in = static_cast<uInt>(in.size());
  std::vector<std::uint8_t> out;
  std::uint8_t chunk[1 << 16];
  int rc = Z_OK;
  while (rc != Z_STREAM_END) {
    zs.next_out = chunk;
    zs.avail_out = sizeof(chunk);
    rc = inflate(&zs, Z_NO_FLUSH);
    if (rc != Z_OK && rc != Z_STREAM_END) {
      inflateEnd(&zs);
      ThrowInputError(source, "",
                      "a complete zlib/gzip-compressed .ingp snapshot (inflate failed: truncated or corrupt)");
    }
    const std::size_t got = sizeof(chunk) - zs.avail_out;
    if (static_cast<std::int64_t>(out.size() + got) > max_bytes) {
      inflateEnd(&zs);
      ThrowInputError(source, "", "a snapshot inflating to at most " + std::to_string(max_bytes) + " bytes");
    }
    out.insert(out.end(), chunk, chunk + got);
    if (rc == Z_OK && got == 0 && zs.avail_in == 0) {
      inflateEnd(&zs);
      ThrowInputError(source, "", "a complete zlib/gzip-compressed .ingp snapshot (truncated)");
    }
  }
  inflateEnd(&zs);
  return out;
}

NgpMlp ReadMlp(const JsonField& f, int inputs, int default_outputs, bool outputs_fixed) {
  NgpMlp m;
  m.otype = f.StringOr("otype", "MLP");
  if (Lower(m.otype) != "fullyfusedmlp") f["otype"].Fail("\"FullyFusedMLP\" (other network types are not supported)");
  if (Lower(f.StringOr("activation", "ReLU")) != "relu") f["activation"].Fail("\"ReLU\"");
  if (Lower(f.StringOr("output_activation", "None")) != "none") f["output_activation"].Fail("\"None\"");
  m.width = static_cast<int>(IntIn(f["n_neurons"], 16, 256));
  if (m.width % 16 != 0) f["n_neurons"].Fail("a multiple of 16 (FullyFusedMLP)");
  m.hidden_layers = static_cast<int>(IntIn(f["n_hidden_layers"], 1, 16));
  m.inputs = inputs;
  m.outputs = outputs_fixed ? default_outputs : static_cast<int>(IntInOr(f, "n_output_dims", 2, 64, default_outputs));
  m.padded_outputs = static_cast<int>(RoundUp(m.outputs, 16));
  return m;
}

int ReadShDegree(const JsonField& f) {
  const std::string otype = Lower(f.StringOr("otype", ""));
  JsonField sh = f;
  if (otype == "composite") {
    if (!f["nested"].json().is_array() || f["nested"].ArraySize() < 1)
      f["nested"].Fail("a non-empty array of encodings");
    sh = f["nested"][0];
    if (IntInOr(sh, "n_dims_to_encode", 0, 16, 3) != 3) sh["n_dims_to_encode"].Fail("3 (the view direction)");
  }
  if (Lower(sh.StringOr("otype", "")) != "sphericalharmonics") sh.Fail("a SphericalHarmonics direction encoding");
  const auto degree = IntIn(sh["degree"], 1, 8);
  if (degree != 4) sh["degree"].Fail("4 (16 coefficients, as our colour network takes)");
  return static_cast<int>(degree);
}

std::array<double, 3> Vec3(const JsonField& f) {
  const auto v = f.Doubles();
  if (v.size() != 3) f.Fail("3 numbers");
  return {v[0], v[1], v[2]};
}

}  // namespace

void NgpReadOptions::Check() const {
  if (max_inflated_bytes < 1) throw std::invalid_argument("NgpReadOptions: max_inflated_bytes must be positive");
}

float HalfToFloat(std::uint16_t h) {
  const std::uint32_t sign = (h >> 15) & 1, exp = (h >> 10) & 0x1f, mant = h & 0x3ff;
  float v;
  if (exp == 0) {
    v = std::ldexp(static_cast<float>(mant), -24);
  } else if (exp == 31) {
    v = mant ? std::numeric_limits<float>::quiet_NaN() : std::numeric_limits<float>::infinity();
  } else {
    v = std::ldexp(static_cast<float>(mant | 0x400), static_cast<int>(exp) - 25);
  }
  return sign ? -v : v;
}

std::uint16_t FloatToHalf(float f) {
  std::uint32_t x;
  std::memcpy(&x, &f, 4);
  const std::uint16_t sign = static_cast<std::uint16_t>((x >> 16) & 0x8000);
  const float a = std::fabs(f);
  if (std::isnan(f)) return sign | 0x7e00;
  if (a >= 65520.f) return sign | 0x7c00;
  if (a < std::ldexp(1.f, -14)) {  // subnormal: multiples of 2^-24
    return sign | static_cast<std::uint16_t>(std::nearbyint(a * std::ldexp(1.f, 24)));
  }
  int e;
  const float m = std::frexp(a, &e);                                                   // a = m 2^e, m in [0.5, 1)
  std::uint32_t mant = static_cast<std::uint32_t>(std::nearbyint(std::ldexp(m, 11)));  // [1024, 2048]
  if (mant == 2048) {
    mant = 1024;
    ++e;
  }
  const std::uint32_t exp = static_cast<std::uint32_t>(e - 1 + 15);
  if (exp >= 31) return sign | 0x7c00;
  return sign | static_cast<std::uint16_t>((exp << 10) | (mant - 1024));
}

std::uint32_t Morton3D(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  auto expand = [](std::uint32_t v) {
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
  };
  return expand(x) | (expand(y) << 1) | (expand(z) << 2);
}

std::vector<NgpGridLevel> NgpGridLevels(const NgpGridEncoding& e) {
  std::vector<NgpGridLevel> out;
  const float log2_scale = std::log2(static_cast<float>(e.per_level_scale));
  const std::int64_t table = std::int64_t(1) << e.log2_table_size;
  std::int64_t offset = 0;
  for (int l = 0; l < e.levels; ++l) {
    NgpGridLevel li;
    li.scale = std::exp2(static_cast<float>(l) * log2_scale) * static_cast<float>(e.base_resolution) - 1.0f;
    // Saturated, not cast out of range: a config this large is refused by the reader.
    li.resolution = li.scale < 16777216.f ? static_cast<std::uint32_t>(std::ceil(li.scale)) + 1 : 16777217u;
    const double dense = std::pow(static_cast<double>(li.resolution), 3);
    const std::int64_t rows = dense > double(table) ? table : RoundUp(static_cast<std::int64_t>(dense), 8);
    li.entries = static_cast<std::uint32_t>(std::min(rows, table));
    li.dense = dense <= double(li.entries);
    li.offset = offset;
    offset += li.entries;
    out.push_back(li);
  }
  return out;
}

std::int64_t NgpMlp::ParamCount() const {
  return std::int64_t(width) * inputs + std::int64_t(hidden_layers - 1) * width * width +
         std::int64_t(padded_outputs) * width;
}

NgpSnapshot ReadNgpSnapshot(const std::string& path, const NgpReadOptions& options) {
  const std::string s = ReadFileToString(path);
  return ParseNgpSnapshot(std::vector<std::uint8_t>(s.begin(), s.end()), path, options);
}

NgpSnapshot ParseNgpSnapshot(const std::vector<std::uint8_t>& raw, const std::string& source,
                             const NgpReadOptions& options) {
  options.Check();
  Json root;
  {
    std::vector<std::uint8_t> inflated;
    const bool compressed = LooksCompressed(raw);
    if (compressed) inflated = Inflate(raw, source, options.max_inflated_bytes);
    if (MsgpackDepthUpTo(compressed ? inflated : raw, kMaxJsonDepth) > kMaxJsonDepth) {
      ThrowInputError(
          source, "",
          "an instant-ngp snapshot nested at most " + std::to_string(kMaxJsonDepth) + " levels deep (arrays and maps)");
    }
    try {
      root = Json::from_msgpack(compressed ? inflated : raw);
    } catch (const Json::exception& e) {
      ThrowInputError(source, "",
                      std::string("an instant-ngp snapshot (msgpack, or zlib-compressed .ingp): ") + e.what());
    }
  }
  if (!root.is_object()) ThrowInputError(source, "", "an instant-ngp snapshot (a msgpack map at the top)");
  const JsonField top(root, source);
  const JsonField snap = top["snapshot"];
  if (!snap.json().is_object()) snap.Fail("an object");
  NgpSnapshot out;

  // Scene box first: the grid's per-level scale may derive from aabb_scale.
  if (snap.Has("nerf") && snap["nerf"].Has("aabb_scale")) {
    out.aabb_scale = static_cast<int>(IntIn(snap["nerf"]["aabb_scale"], 1, 128));
    if ((out.aabb_scale & (out.aabb_scale - 1)) != 0) snap["nerf"]["aabb_scale"].Fail("a power of 2 in [1, 128]");
  }
  if (snap.Has("aabb")) {
    out.aabb_min = Vec3(snap["aabb"]["min"]);
    out.aabb_max = Vec3(snap["aabb"]["max"]);
    for (int k = 0; k < 3; ++k)
      if (!(out.aabb_max[k] > out.aabb_min[k]) || std::fabs(out.aabb_min[k]) > 1e4 || std::fabs(out.aabb_max[k]) > 1e4)
        snap["aabb"].Fail("{min, max} with max > min, within 1e4");
  } else {
    for (int k = 0; k < 3; ++k) {
      out.aabb_min[k] = 0.5 - 0.5 * out.aabb_scale;
      out.aabb_max[k] = 0.5 + 0.5 * out.aabb_scale;
    }
  }
  if (snap.Has("nerf") && snap["nerf"].Has("dataset")) {
    const JsonField ds = snap["nerf"]["dataset"];
    if (ds.Has("scale")) {
      out.scale = ds["scale"].Double();
      if (!(out.scale > 0)) ds["scale"].Fail("a positive number");
      out.has_dataset_transform = true;
    }
    if (ds.Has("offset")) {
      out.offset = Vec3(ds["offset"]);
      out.has_dataset_transform = true;
    }
  }

  // Position encoding.
  const JsonField enc = top["encoding"];
  const std::string otype = Lower(enc.StringOr("otype", ""));
  if (!(otype == "hashgrid" || (otype == "grid" && Lower(enc.StringOr("type", "hash")) == "hash"))) {
    enc["otype"].Fail("\"HashGrid\" (other position encodings are not supported)");
  }
  auto& e = out.encoding;
  e.levels = static_cast<int>(IntIn(enc["n_levels"], 1, 32));
  e.features = static_cast<int>(IntIn(enc["n_features_per_level"], 1, 8));
  e.log2_table_size = static_cast<int>(IntIn(enc["log2_hashmap_size"], 4, 24));
  e.base_resolution = static_cast<int>(IntIn(enc["base_resolution"], 1, 1 << 16));
  e.interpolation = enc.StringOr("interpolation", "Linear");
  if (Lower(e.interpolation) != "linear") enc["interpolation"].Fail("\"Linear\"");
  e.per_level_scale = enc.DoubleOr("per_level_scale", 0.0);
  if (!(e.per_level_scale > 0)) {  // instant-ngp's rule: the finest level reaches 2048 * aabb_scale
    e.per_level_scale =
        e.levels > 1
            ? std::exp(std::log(2048.0f * float(out.aabb_scale) / float(e.base_resolution)) / float(e.levels - 1))
            : 1.0;
  }
  if (!(e.per_level_scale >= 1.0 && e.per_level_scale <= 16.0)) enc["per_level_scale"].Fail("a number in [1, 16]");
  const auto levels = NgpGridLevels(e);
  for (const auto& li : levels)
    if (!(li.scale < 16777216.f)) enc.Fail("a grid whose finest resolution fits 2^24");

  // Networks, as instant-ngp's NerfNetwork builds them.
  const int encoding_width = static_cast<int>(RoundUp(std::int64_t(e.levels) * e.features, 16));
  out.density_network = ReadMlp(top["network"], encoding_width, 16, false);
  out.sh_degree = ReadShDegree(top["dir_encoding"]);
  const int dir_width = static_cast<int>(RoundUp(out.sh_degree * out.sh_degree, 16));
  if (dir_width != out.sh_degree * out.sh_degree) top["dir_encoding"].Fail("an encoding without padding");
  out.rgb_network = ReadMlp(top["rgb_network"],
                            static_cast<int>(RoundUp(out.density_network.padded_outputs + dir_width, 16)), 3, true);

  out.density_params_offset = 0;
  out.rgb_params_offset = out.density_network.ParamCount();
  out.grid_params_offset = out.rgb_params_offset + out.rgb_network.ParamCount();
  const std::int64_t expected = out.grid_params_offset + (levels.back().offset + levels.back().entries) * e.features;

  // Parameters: the count is checked against the configuration and the bytes before allocating.
  const std::int64_t n_params = IntIn(snap["n_params"], 0, std::numeric_limits<std::int64_t>::max() / 8);
  if (n_params != expected) {
    snap["n_params"].Fail(std::to_string(expected) + " for this encoding and these networks (the file claims " +
                          std::to_string(n_params) + ")");
  }
  const std::string params_type = snap.StringOr("params_type", "__half");
  const std::int64_t elem = params_type == "__half" ? 2 : params_type == "float" ? 4 : 0;
  if (elem == 0) snap["params_type"].Fail("\"__half\" or \"float\"");
  const auto& bin = Binary(snap["params_binary"]);
  if (static_cast<std::int64_t>(bin.size()) != n_params * elem) {
    snap["params_binary"].Fail(std::to_string(n_params * elem) + " bytes (n_params x " + std::to_string(elem) +
                               "), got " + std::to_string(bin.size()));
  }
  out.params.resize(static_cast<std::size_t>(n_params));
  for (std::int64_t i = 0; i < n_params; ++i) {
    float v;
    if (elem == 2) {
      std::uint16_t h;
      std::memcpy(&h, bin.data() + 2 * i, 2);
      v = HalfToFloat(h);
    } else {
      std::memcpy(&v, bin.data() + 4 * i, 4);
    }
    if (!std::isfinite(v)) snap["params_binary"].Fail("finite weights (parameter " + std::to_string(i) + " is not)");
    out.params[static_cast<std::size_t>(i)] = v;
  }

  // Density grid (optional): fp16 cells in Morton order, cascade after cascade.
  if (snap.Has("density_grid_binary")) {
    const int g = static_cast<int>(IntIn(snap["density_grid_size"], 1, 512));
    if ((g & (g - 1)) != 0) snap["density_grid_size"].Fail("a power of 2 in [1, 512]");
    const auto& grid = Binary(snap["density_grid_binary"]);
    const std::int64_t cells = std::int64_t(g) * g * g;
    if (grid.size() % (2 * cells) != 0 || grid.empty() || grid.size() / (2 * cells) > 8) {
      snap["density_grid_binary"].Fail("1 to 8 cascades of density_grid_size^3 fp16 values (" +
                                       std::to_string(2 * cells) + " bytes each), got " + std::to_string(grid.size()) +
                                       " bytes");
    }
    out.density_grid_size = g;
    out.density_cascades = static_cast<int>(grid.size() / (2 * cells));
    out.density_grid.resize(static_cast<std::size_t>(cells * out.density_cascades));
    for (int c = 0; c < out.density_cascades; ++c)
      for (int z = 0; z < g; ++z)
        for (int y = 0; y < g; ++y)
          for (int x = 0; x < g; ++x) {
            std::uint16_t h;
            std::memcpy(&h, grid.data() + 2 * (c * cells + Morton3D(x, y, z)), 2);
            out.density_grid[static_cast<std::size_t>(c * cells + (std::int64_t(z) * g + y) * g + x)] = HalfToFloat(h);
          }
  }
  return out;
}

}  // namespace nerfreg
