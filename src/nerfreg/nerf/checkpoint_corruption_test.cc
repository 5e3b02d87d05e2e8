// The corrupt-checkpoint battery: NeRF checkpoints are torch archives (zip + pickle), which the
// torch-free sanitizer build cannot fuzz, so a saved block is corrupted deterministically here
// (truncations, byte flips in the zip headers, the central directory and the data) and every
// corruption must either load or throw InputError naming the file: never crash, never throw
// anything else.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(CheckpointCorruption, EveryCorruptionLoadsOrIsAnInputErrorNamingTheFile) {
  ScopedTempDir dir;
  FieldOptions fo;
  fo.encoding.levels = 2;
  fo.encoding.log2_table_size = 6;
  fo.hidden_dim = 16;
  OccupancyGridOptions go;
  go.resolution = 8;
  NerfBlock block = NerfBlock::Create(fo, go, MarchOptions{}, 1);
  const std::string good = dir.File("good.ckpt");
  SaveNerfBlock(block, good);
  LoadNerfBlock(good);  // the uncorrupted file loads (a block without cameras included)
  const std::string bytes = ReadFileToString(good);
  const std::int64_t n = static_cast<std::int64_t>(bytes.size());
  ASSERT_GT(n, 1000);

  std::vector<std::string> cases;
  // Truncations at 40 offsets (the first bytes, everywhere, the last bytes).
  for (std::int64_t len : {0, 1, 4, 30, 100}) cases.push_back(bytes.substr(0, len));
  for (int k = 1; k <= 30; ++k) cases.push_back(bytes.substr(0, n * k / 31));
  for (std::int64_t cut : {1, 2, 22, 100, 300}) cases.push_back(bytes.substr(0, n - cut));
  // Byte flips: local headers (start), central directory (end), data (middle).
  std::mt19937 rng(7);
  auto flipped = [&](std::int64_t lo, std::int64_t hi, int flips) {
    std::string s = bytes;
    std::uniform_int_distribution<std::int64_t> at(std::max<std::int64_t>(lo, 0), std::min(hi, n) - 1);
    std::uniform_int_distribution<int> value(0, 255);
    for (int f = 0; f < flips; ++f) s[at(rng)] = static_cast<char>(value(rng));
    return s;
  };
  for (int k = 0; k < 20; ++k) cases.push_back(flipped(0, 200, 1 + k % 3));
  for (int k = 0; k < 20; ++k) cases.push_back(flipped(n - 400, n, 1 + k % 3));
  for (int k = 0; k < 20; ++k) cases.push_back(flipped(200, n - 400, 1 + k % 4));
  ASSERT_GE(cases.size(), 100u);

  int loaded = 0, refused = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = dir.File("bad_" + std::to_string(i) + ".ckpt");
    WriteFileAtomic(path, cases[i]);
    try {
      LoadNerfBlock(path);
      ++loaded;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path, 0), 0u) << "case " << i << ": " << e.what();
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "case " << i << " threw a non-InputError: " << e.what();
    }
  }
  EXPECT_GE(refused, 45);  // every truncation at least
  RecordProperty("loaded", loaded);
}

// Found by fuzz/torch_archive_fuzz.cc: a checkpoint whose stored field options claim a huge MLP
// (hidden_dim 400000: ~600 GB of weights) or 2*10^8 colour layers made the loader allocate until
// the process died. Sizes the file cannot hold are now refused before the field is built.
TEST(CheckpointCorruption, StoredSizesTheFileCannotHoldAreInputErrors) {
  ScopedTempDir dir;
  FieldOptions fo;
  fo.encoding.levels = 2;
  fo.encoding.log2_table_size = 6;
  fo.hidden_dim = 16;
  OccupancyGridOptions go;
  go.resolution = 8;
  for (int k = 0; k < 2; ++k) {
    NerfBlock block = NerfBlock::Create(fo, go, MarchOptions{}, 1);
    if (k == 0) block.field_options.hidden_dim = 400000;
    if (k == 1) block.field_options.color_hidden_layers = 200000000;
    const std::string path = dir.File("huge_" + std::to_string(k) + ".ckpt");
    SaveNerfBlock(block, path);  // the options as stored; the tensors are the small field's
    const std::string e = InputErrorOf([&] { LoadNerfBlock(path); });
    EXPECT_EQ(e.rfind(path + ": field:", 0), 0u) << e;
    EXPECT_NE(e.find("parameters"), std::string::npos) << e;
  }
}

}  // namespace
}  // namespace nerfreg
