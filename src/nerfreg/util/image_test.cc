#include "nerfreg/util/image.h"

#include <gtest/gtest.h>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(Image, PngRoundTripRgba) {
  ScopedTempDir dir;
  Image im(7, 5, 4);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x)
      for (int c = 0; c < 4; ++c) im.at(x, y, c) = ((x * 31 + y * 17 + c * 5) % 256) / 255.f;
  WriteImage(dir.File("a.png"), im);
  const Image back = ReadImage(dir.File("a.png"));
  ASSERT_EQ(back.width, 7);
  ASSERT_EQ(back.height, 5);
  ASSERT_EQ(back.channels, 4);
  for (size_t i = 0; i < im.data.size(); ++i) EXPECT_NEAR(back.data[i], im.data[i], 1e-6);
}

TEST(Image, JpegRoundTripIsClose) {
  ScopedTempDir dir;
  Image im(16, 16, 3, 0.5f);
  WriteImage(dir.File("a.jpg"), im);
  const Image back = ReadImage(dir.File("a.jpg"), 3);
  for (float v : back.data) EXPECT_NEAR(v, 0.5f, 0.02f);
}

TEST(Image, CorruptAndMissingImagesAreInputErrors) {
  ScopedTempDir dir;
  EXPECT_THROW(ReadImage(dir.File("none.png")), InputError);
  WriteFileAtomic(dir.File("bad.png"), "not a png at all");
  EXPECT_THROW(ReadImage(dir.File("bad.png")), InputError);
}

TEST(Image, HugeHeaderRefusedBeforeDecoding) {
  // A PNG header claiming 100000 x 100000 pixels: must be refused without allocating.
  ScopedTempDir dir;
  Image tiny(1, 1, 3, 1.f);
  WriteImage(dir.File("t.png"), tiny);
  std::string bytes = ReadFileToString(dir.File("t.png"));
  // IHDR width/height are big-endian at byte offsets 16 and 20.
  auto put = [&](size_t off, unsigned v) {
    bytes[off] = char(v >> 24);
    bytes[off + 1] = char(v >> 16);
    bytes[off + 2] = char(v >> 8);
    bytes[off + 3] = char(v);
  };
  put(16, 100000);
  put(20, 100000);
  WriteFileAtomic(dir.File("huge.png"), bytes);
  EXPECT_THROW(ReadImage(dir.File("huge.png")), InputError);
}

TEST(Image, PngChunkLongerThanTheFileIsRefusedBeforeAllocating) {
  // A 4x3 PNG whose IDAT chunk claims 0xFFFFFFFF bytes (a fuzzer finding: stb allocated them).
  ScopedTempDir dir;
  Image tiny(4, 3, 3, 0.5f);
  WriteImage(dir.File("t.png"), tiny);
  std::string bytes = ReadFileToString(dir.File("t.png"));
  const size_t idat = bytes.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  for (int k = 0; k < 4; ++k) bytes[idat - 4 + k] = '\xff';
  WriteFileAtomic(dir.File("hostile.png"), bytes);
  try {
    ReadImage(dir.File("hostile.png"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("hostile.png: PNG chunk"), std::string::npos) << e.what();
  }
}

TEST(Image, CompositeOverWhite) {
  Image rgba(1, 1, 4);
  rgba.data = {1.f, 0.f, 0.f, 0.25f};
  const Image rgb = CompositeOver(rgba, 1, 1, 1);
  EXPECT_FLOAT_EQ(rgb.data[0], 1.f);
  EXPECT_FLOAT_EQ(rgb.data[1], 0.75f);
}

TEST(Image, ContactSheetTilesImages) {
  std::vector<Image> ims = {Image(4, 3, 3, 0.f), Image(4, 3, 4, 1.f), Image(2, 2, 1, 0.5f)};
  const Image sheet = ContactSheet(ims, 2);
  EXPECT_EQ(sheet.width, 2 * 4 + 2);
  EXPECT_EQ(sheet.height, 2 * 3 + 2);
  EXPECT_FLOAT_EQ(sheet.at(0, 0, 0), 0.f);   // first image
  EXPECT_FLOAT_EQ(sheet.at(6, 0, 1), 1.f);   // second (opaque white)
  EXPECT_FLOAT_EQ(sheet.at(4, 0, 0), 1.f);   // gap
  EXPECT_FLOAT_EQ(sheet.at(1, 6, 2), 0.5f);  // third, grey
}

}  // namespace
}  // namespace nerfreg
