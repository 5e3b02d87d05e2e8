#include "nerfreg/data/ngp_snapshot.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nerfreg/data/ngp_test_snapshot.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(NgpSnapshot, HalfConversionRoundTripsEveryHalf) {
  for (std::uint32_t h = 0; h < 65536; ++h) {
    const float f = HalfToFloat(static_cast<std::uint16_t>(h));
    if (std::isnan(f)) continue;
    ASSERT_EQ(FloatToHalf(f), h) << h;
  }
  EXPECT_EQ(HalfToFloat(0x3c00), 1.0f);
  EXPECT_EQ(HalfToFloat(0xc000), -2.0f);
  EXPECT_EQ(HalfToFloat(0x0001), std::ldexp(1.0f, -24));
  EXPECT_TRUE(std::isinf(HalfToFloat(0x7c00)));
}

TEST(NgpSnapshot, MortonInterleavesXLowest) {
  EXPECT_EQ(Morton3D(1, 0, 0), 1u);
  EXPECT_EQ(Morton3D(0, 1, 0), 2u);
  EXPECT_EQ(Morton3D(0, 0, 1), 4u);
  EXPECT_EQ(Morton3D(2, 0, 0), 8u);
  EXPECT_EQ(Morton3D(127, 127, 127), 128u * 128u * 128u - 1);
  for (std::uint32_t x = 0; x < 16; x += 3)
    for (std::uint32_t y = 0; y < 16; y += 5)
      for (std::uint32_t z = 0; z < 16; z += 7) EXPECT_EQ(Morton3D(x, y, z), TestMorton(x, y, z));
}

TEST(NgpSnapshot, GridLevelsFollowTinyCudaNn) {
  NgpGridEncoding e;
  e.levels = 4;
  e.features = 4;
  e.log2_table_size = 10;
  e.base_resolution = 4;
  e.per_level_scale = 1.5;
  const auto levels = NgpGridLevels(e);
  ASSERT_EQ(levels.size(), 4u);
  // scale = 1.5^l * 4 - 1 = 3, 5, 8, 12.5; resolution = ceil + 1; rows = min(round8(res^3), 2^10).
  const std::uint32_t res[] = {4, 6, 9, 14}, rows[] = {64, 216, 736, 1024};
  std::int64_t offset = 0;
  for (int l = 0; l < 4; ++l) {
    EXPECT_EQ(levels[l].resolution, res[l]);
    EXPECT_EQ(levels[l].entries, rows[l]);
    EXPECT_EQ(levels[l].dense, l < 3);
    EXPECT_EQ(levels[l].offset, offset);
    offset += rows[l];
  }
  EXPECT_FLOAT_EQ(levels[3].scale, 12.5f);
}

TEST(NgpSnapshot, ReadsMsgpackAndIngp) {
  ScopedTempDir dir;
  const TestNgpSnapshot t = MakeTestNgpSnapshot();
  for (bool compressed : {false, true}) {
    const std::string path = dir.File(compressed ? "s.ingp" : "s.msgpack");
    WriteTestNgpSnapshot(t.json, path, compressed);
    const NgpSnapshot s = ReadNgpSnapshot(path);
    EXPECT_EQ(s.encoding.levels, 4);
    EXPECT_EQ(s.encoding.features, 4);
    EXPECT_EQ(s.encoding.log2_table_size, 10);
    EXPECT_DOUBLE_EQ(s.encoding.per_level_scale, 1.5);
    EXPECT_EQ(s.density_network.inputs, 16);
    EXPECT_EQ(s.density_network.outputs, 16);
    EXPECT_EQ(s.rgb_network.inputs, 32);
    EXPECT_EQ(s.rgb_network.hidden_layers, 2);
    EXPECT_EQ(s.rgb_network.padded_outputs, 16);
    EXPECT_EQ(s.rgb_params_offset, 16 * 16 + 16 * 16);
    EXPECT_EQ(s.grid_params_offset, s.rgb_params_offset + 16 * 32 + 16 * 16 + 16 * 16);
    ASSERT_EQ(s.params, t.params);
    EXPECT_EQ(s.aabb_scale, 2);
    EXPECT_DOUBLE_EQ(s.aabb_min[1], -0.5);
    EXPECT_DOUBLE_EQ(s.aabb_max[2], 1.5);
    EXPECT_TRUE(s.has_dataset_transform);
    EXPECT_DOUBLE_EQ(s.scale, 0.25);
    EXPECT_DOUBLE_EQ(s.offset[1], 0.4);
    ASSERT_EQ(s.density_grid_size, 16);
    ASSERT_EQ(s.density_cascades, 2);
    ASSERT_EQ(s.density_grid.size(), t.occupied.size());
    for (size_t i = 0; i < t.occupied.size(); ++i) ASSERT_EQ(s.density_grid[i], t.occupied[i] ? 1.0f : 0.0f) << i;
  }
}

TEST(NgpSnapshot, ReadsGzipIngpAsInstantNgpWritesIt) {
  // instant-ngp compresses .ingp with zstr (deflate with a gzip header).
  const TestNgpSnapshot t = MakeTestNgpSnapshot();
  std::vector<std::uint8_t> raw = nlohmann::json::to_msgpack(t.json), gz(raw.size() + 1024);
  z_stream zs{};
  ASSERT_EQ(deflateInit2(&zs, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  zs.next_in = raw.data();
  zs.avail_in = static_cast<uInt>(raw.size());
  zs.next_out = gz.data();
  zs.avail_out = static_cast<uInt>(gz.size());
  ASSERT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  gz.resize(zs.total_out);
  deflateEnd(&zs);
  ASSERT_EQ(gz[0], 0x1f);
  const NgpSnapshot s = ParseNgpSnapshot(gz, "s.ingp");
  EXPECT_EQ(s.params, t.params);
  EXPECT_EQ(s.density_cascades, 2);
}

TEST(NgpSnapshot, PerLevelScaleDefaultsToInstantNgpRule) {
  TestNgpSnapshot t = MakeTestNgpSnapshot();
  t.json["encoding"].erase("per_level_scale");
  // exp(ln(2048 * 2 / 4) / 3) = 1024^(1/3) ~ 10.08: the grid grows, so n_params no longer matches.
  const auto bytes = TestNgpSnapshotBytes(t.json, false);
  const std::string err = InputErrorOf([&] { ParseNgpSnapshot(bytes, "s.msgpack"); });
  EXPECT_NE(err.find("s.msgpack: snapshot.n_params: expected"), std::string::npos) << err;
}

TEST(NgpSnapshot, BadInputsAreInputErrors) {
  const TestNgpSnapshot t = MakeTestNgpSnapshot();
  auto error_of = [](const nlohmann::json& j, bool compressed = false) {
    const auto bytes = TestNgpSnapshotBytes(j, compressed);
    return InputErrorOf([&] { ParseNgpSnapshot(bytes, "s.msgpack"); });
  };
  // Truncated, plain and compressed.
  for (bool compressed : {false, true}) {
    auto bytes = TestNgpSnapshotBytes(t.json, compressed);
    bytes.resize(bytes.size() * 2 / 3);
    const std::string err = InputErrorOf([&] { ParseNgpSnapshot(bytes, "s.msgpack"); });
    EXPECT_EQ(err.rfind("s.msgpack: expected", 0), 0u) << err;
  }
  auto j = t.json;
  j["snapshot"]["n_params"] = t.params.size() + 1;
  EXPECT_NE(error_of(j).find("snapshot.n_params: expected " + std::to_string(t.params.size())), std::string::npos);
  j["snapshot"]["n_params"] = std::uint64_t(1000000000000ull);
  EXPECT_NE(error_of(j).find("snapshot.n_params: expected"), std::string::npos);
  j = t.json;
  j["snapshot"]["params_binary"] = nlohmann::json::binary(std::vector<std::uint8_t>(10));
  EXPECT_NE(error_of(j).find("snapshot.params_binary: expected"), std::string::npos);
  j = t.json;
  j["encoding"]["otype"] = "Frequency";
  EXPECT_NE(error_of(j).find("encoding.otype: expected \"HashGrid\""), std::string::npos);
  j = t.json;
  j["encoding"]["n_levels"] = -3;
  EXPECT_NE(error_of(j).find("encoding.n_levels: expected an integer in [1, 32]"), std::string::npos);
  j = t.json;
  j["encoding"]["base_resolution"] = 0u;  // msgpack's unsigned 0 (found by fuzzing: it slipped past the lower bound)
  EXPECT_NE(error_of(j).find("encoding.base_resolution: expected an integer in [1, 65536]"), std::string::npos);
  j = t.json;
  j["network"]["otype"] = "CutlassMLP";
  EXPECT_NE(error_of(j).find("network.otype: expected"), std::string::npos);
  j = t.json;
  j["snapshot"]["density_grid_binary"] = nlohmann::json::binary(std::vector<std::uint8_t>(16 * 16 * 16 * 2 + 2));
  EXPECT_NE(error_of(j).find("snapshot.density_grid_binary: expected"), std::string::npos);
  j = t.json;
  j["snapshot"].erase("params_binary");
  EXPECT_NE(error_of(j).find("snapshot.params_binary: expected a value"), std::string::npos);
  EXPECT_NE(error_of(nlohmann::json::array({1, 2})).find("expected an instant-ngp snapshot"), std::string::npos);
  // A zip bomb is bounded: the inflate limit is an error, not an allocation.
  NgpReadOptions small;
  small.max_inflated_bytes = 1000;
  const auto bytes = TestNgpSnapshotBytes(t.json, true);
  EXPECT_NE(InputErrorOf([&] { ParseNgpSnapshot(bytes, "s.ingp", small); }).find("inflating to at most 1000 bytes"),
            std::string::npos);
}

// Deep nesting is refused before nlohmann's recursive msgpack reader sees it: 3 MB of fixarray-of-1
// bytes (a 3 KB .ingp) overflowed the stack. Every msgpack container form counts, and a real
// snapshot, with its binary blobs and strings skipped correctly, passes.
TEST(NgpSnapshot, DeepNestingIsAnInputErrorNotAStackOverflow) {
  const std::string expected = "d.ingp: expected an instant-ngp snapshot nested at most 64 levels deep";
  std::vector<std::uint8_t> deep(3000000, 0x91);
  deep.push_back(0x00);
  EXPECT_NE(InputErrorOf([&] { ParseNgpSnapshot(deep, "d.ingp"); }).find(expected), std::string::npos);
  // array16 / map16 / map32 forms of one child each, and a fixmap of one pair ({0: ...}).
  for (const std::vector<std::uint8_t>& level : std::vector<std::vector<std::uint8_t>>{
           {0xdc, 0x00, 0x01}, {0xde, 0x00, 0x01, 0x00}, {0xdf, 0x00, 0x00, 0x00, 0x01, 0x00}, {0x81, 0x00}}) {
    std::vector<std::uint8_t> bytes;
    for (int k = 0; k < 100; ++k) bytes.insert(bytes.end(), level.begin(), level.end());
    bytes.push_back(0xc0);
    EXPECT_NE(InputErrorOf([&] { ParseNgpSnapshot(bytes, "d.ingp"); }).find(expected), std::string::npos)
        << int(level[0]);
  }
  // Siblings are not depth: 100 arrays side by side inside one array.
  std::vector<std::uint8_t> wide = {0xdc, 0x00, 100};
  for (int k = 0; k < 100; ++k) wide.insert(wide.end(), {0x91, 0x91, 0xc0});
  EXPECT_EQ(InputErrorOf([&] { ParseNgpSnapshot(wide, "w.ingp"); }).find("nested at most"), std::string::npos);
  const TestNgpSnapshot t = MakeTestNgpSnapshot();
  for (bool compressed : {false, true}) {
    EXPECT_EQ(InputErrorOf([&] { ParseNgpSnapshot(TestNgpSnapshotBytes(t.json, compressed), "s.ingp"); }), "");
  }
}

}  // namespace
}  // namespace nerfreg
