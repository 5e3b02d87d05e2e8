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
#include "nerfreg/util/torch_archive.h"

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

// Found by fuzz/torch_archive_fuzz.cc: LibTorch reads zip entries without checking their CRC-32,
// so a changed length inside data.pkl reached its unpickler, which reserved 4 GB for it. Every
// stored entry's CRC is now checked first: one changed byte of the pickle is refused, naming it.
TEST(CheckpointCorruption, AChangedByteInsideThePickleFailsItsCrc) {
  ScopedTempDir dir;
  FieldOptions fo;
  fo.encoding.levels = 2;
  fo.encoding.log2_table_size = 6;
  fo.hidden_dim = 16;
  OccupancyGridOptions go;
  go.resolution = 8;
  NerfBlock block = NerfBlock::Create(fo, go, MarchOptions{}, 1);
  const std::string good = dir.File("good.ckpt"), path = dir.File("flipped.ckpt");
  SaveNerfBlock(block, good);
  EXPECT_EQ(ZipArchiveProblem(ReadFileToString(good)), "");
  std::string bytes = ReadFileToString(good);
  // The local header of the first data.pkl: name and extra lengths at +26 / +28, data after them.
  const size_t name = bytes.find("data.pkl");
  ASSERT_NE(name, std::string::npos);
  size_t local = bytes.rfind("PK\x03\x04", name);
  ASSERT_NE(local, std::string::npos);
  auto u16 = [&](size_t o) { return size_t(std::uint8_t(bytes[o])) | size_t(std::uint8_t(bytes[o + 1])) << 8; };
  const size_t data = local + 30 + u16(local + 26) + u16(local + 28);
  bytes[data + 2] = static_cast<char>(bytes[data + 2] ^ 0x40);
  WriteFileAtomic(path, bytes);
  const std::string e = InputErrorOf([&] { LoadNerfBlock(path); });
  EXPECT_EQ(e.rfind(path + ": expected a nerfreg NeRF checkpoint", 0), 0u) << e;
  EXPECT_NE(e.find("data.pkl fails its CRC-32"), std::string::npos) << e;
}

// Found by fuzz/torch_archive_fuzz.cc: LibTorch 1.13's reader leaks its zip state when it throws
// while opening an archive, as it does when the version record is missing. A changed byte in that
// entry's central-directory name did it (CRCs cover data, not names). The layout is now checked
// before LibTorch opens the file: names must match their local headers, share one top folder and
// include the version record.
TEST(CheckpointCorruption, AChangedEntryNameIsRefusedBeforeLibTorchOpensTheFile) {
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
  const std::string bytes = ReadFileToString(good);
  // The central directory comes after every local header: the last "/version" is its name there.
  const size_t name = bytes.rfind("/version");
  ASSERT_NE(name, std::string::npos);
  std::string renamed = bytes, moved = bytes;
  renamed[name + 7] = 'm';  // ".../versiom": not the local header's name, and no version record
  moved[name - 1] = static_cast<char>(moved[name - 1] ^ 0x40);  // the folder's last byte
  EXPECT_NE(ZipArchiveProblem(renamed).find("another name in its local header"), std::string::npos)
      << ZipArchiveProblem(renamed);
  EXPECT_NE(ZipArchiveProblem(moved).find("outside the archive's folder"), std::string::npos)
      << ZipArchiveProblem(moved);
  for (const std::string* b : {&renamed, &moved}) {
    const std::string path = dir.File(b == &renamed ? "renamed.ckpt" : "moved.ckpt");
    WriteFileAtomic(path, *b);
    const std::string e = InputErrorOf([&] { LoadNerfBlock(path); });
    EXPECT_EQ(e.rfind(path + ": expected a nerfreg NeRF checkpoint (unreadable or truncated: zip entry", 0), 0u) << e;
  }
}

// Found by fuzz/torch_archive_fuzz.cc: a checkpoint whose meta has no "cameras" read a missing key
// of a const JSON object (undefined behaviour; an assertion in the fuzz build). Now an InputError.
TEST(CheckpointCorruption, MetaWithoutCamerasIsAnInputErrorNamingTheField) {
  ScopedTempDir dir;
  FieldOptions fo;
  fo.encoding.levels = 2;
  fo.encoding.log2_table_size = 6;
  fo.hidden_dim = 16;
  OccupancyGridOptions go;
  go.resolution = 8;
  NerfBlock block = NerfBlock::Create(fo, go, MarchOptions{}, 1);
  const std::string good = dir.File("good.ckpt"), path = dir.File("no_cameras.ckpt");
  SaveNerfBlock(block, good);
  // The same archive with "cameras" taken out of its meta.
  torch::serialize::InputArchive in;
  in.load_from(good);
  torch::Tensor meta_tensor;
  in.read("meta", meta_tensor);
  Json meta = Json::parse(TensorString(meta_tensor));
  meta.erase("cameras");
  torch::serialize::OutputArchive out, field;
  out.write("meta", StringTensor(meta.dump()));
  block.field->save(field);
  out.write("field", field);
  out.write("grid_density", block.grid->density());
  out.write("grid_occupied", block.grid->occupied().to(torch::kUInt8));
  out.save_to(path);
  const std::string e = InputErrorOf([&] { LoadNerfBlock(path); });
  EXPECT_EQ(e.rfind(path + ": cameras:", 0), 0u) << e;
}

}  // namespace
}  // namespace nerfreg
