#include "nerfreg/util/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

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

// A 48x32 test card: grey, a red 16x16 block at the top-left corner, a blue one at the top-right.
Image TestCard() {
  Image im(48, 32, 3, 0.5f);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      im.at(x, y, 0) = 1, im.at(x, y, 1) = 0, im.at(x, y, 2) = 0;
      im.at(47 - x, y, 0) = 0, im.at(47 - x, y, 1) = 0, im.at(47 - x, y, 2) = 1;
    }
  return im;
}

// 'r', 'b' or 'g' (grey): the colour at (x, y) of a decoded test card.
char ColourAt(const Image& im, int x, int y) {
  const float r = im.at(x, y, 0), g = im.at(x, y, 1), b = im.at(x, y, 2);
  if (r > 0.8f && g < 0.2f && b < 0.2f) return 'r';
  if (b > 0.8f && r < 0.2f && g < 0.2f) return 'b';
  if (std::abs(r - 0.5f) < 0.1f && std::abs(g - 0.5f) < 0.1f && std::abs(b - 0.5f) < 0.1f) return 'g';
  return '?';
}

// The colours at the centres of the four corner blocks: top-left, top-right, bottom-left,
// bottom-right.
std::string Corners(const Image& im) {
  const int r = im.width - 9, b = im.height - 9;
  return {ColourAt(im, 8, 8), ColourAt(im, r, 8), ColourAt(im, 8, b), ColourAt(im, r, b)};
}

TEST(Image, JpegExifOrientationIsApplied) {
  ScopedTempDir dir;
  struct Case {
    int orientation;
    int width, height;    // upright
    const char* corners;  // top-left, top-right, bottom-left, bottom-right
  };
  // The stored card has red top-left and blue top-right ("rbgg").
  const Case cases[] = {
      {1, 48, 32, "rbgg"},  // as stored
      {2, 48, 32, "brgg"},  // mirrored left-right
      {3, 48, 32, "ggbr"},  // turned 180 degrees
      {4, 48, 32, "ggrb"},  // mirrored top-bottom
      {5, 32, 48, "rgbg"},  // transposed: the stored top row becomes the left column
      {6, 32, 48, "grgb"},  // turned 90 degrees clockwise: the stored top row becomes the right column
      {7, 32, 48, "gbgr"},  // transversed: the stored top row becomes the right column, reversed
      {8, 32, 48, "bgrg"},  // turned 90 degrees counter-clockwise: the top row becomes the left column
  };
  for (const Case& c : cases) {
    TestExif exif;
    exif.orientation = static_cast<std::uint16_t>(c.orientation);
    const std::string path = dir.File("o" + std::to_string(c.orientation) + ".jpg");
    WriteJpegWithExif(path, TestCard(), exif);
    ImageFileFacts facts;
    const Image im = ReadImage(path, ImageReadOptions(), &facts);
    EXPECT_EQ(im.width, c.width) << c.orientation;
    EXPECT_EQ(im.height, c.height) << c.orientation;
    EXPECT_EQ(Corners(im), c.corners) << c.orientation;
    EXPECT_EQ(facts.orientation_applied, c.orientation);
    EXPECT_EQ(facts.stored_width, 48);
    EXPECT_EQ(ReadImageOrientation(path), c.orientation);
    int w = 0, h = 0, ch = 0;
    ReadImageSize(path, &w, &h, &ch);
    EXPECT_EQ(w, c.width) << c.orientation;
    EXPECT_EQ(h, c.height) << c.orientation;
    EXPECT_EQ(ch, 3);
    // Asked not to turn it: the stored pixels.
    ImageReadOptions as_stored;
    as_stored.apply_exif_orientation = false;
    const Image stored = ReadImage(path, as_stored, &facts);
    EXPECT_EQ(Corners(stored), "rbgg") << c.orientation;
    EXPECT_EQ(facts.orientation_applied, 1);
    EXPECT_EQ(facts.exif.orientation, c.orientation);
  }
}

TEST(Image, GreyAndGreyAlphaPngs) {
  ScopedTempDir dir;
  Image grey(3, 2, 1);
  grey.data = {0.f, 10 / 255.f, 100 / 255.f, 128 / 255.f, 200 / 255.f, 1.f};
  WriteImage(dir.File("g.png"), grey);
  const Image g = ReadImage(dir.File("g.png"));
  ASSERT_EQ(g.channels, 1);
  for (size_t i = 0; i < g.data.size(); ++i) EXPECT_FLOAT_EQ(g.data[i], grey.data[i]);

  Image ga(2, 1, 2);
  ga.data = {40 / 255.f, 1.f, 220 / 255.f, 60 / 255.f};  // (grey, alpha) per pixel
  WriteImage(dir.File("ga.png"), ga);
  ImageFileFacts facts;
  const Image rgba = ReadImage(dir.File("ga.png"), ImageReadOptions(), &facts);
  EXPECT_EQ(facts.file_channels, 2);
  ASSERT_EQ(rgba.channels, 4);  // an Image holds 1, 3 or 4 channels
  for (int x = 0; x < 2; ++x) {
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(rgba.at(x, 0, c), ga.data[x * 2]);
    EXPECT_FLOAT_EQ(rgba.at(x, 0, 3), ga.data[x * 2 + 1]);
  }
  EXPECT_EQ(ReadImage(dir.File("ga.png"), 1).channels, 1);
}

TEST(Image, SixteenBitPngsKeepTheirPrecision) {
  ScopedTempDir dir;
  // 12345 / 65535 = 0.188373; its 8-bit reduction would be 48 / 255 = 0.188235.
  const std::vector<std::uint16_t> grey = {0, 1, 257, 12345, 32768, 65535};
  WritePng16(dir.File("g16.png"), 3, 2, 1, grey);
  ImageFileFacts facts;
  const Image g = ReadImage(dir.File("g16.png"), ImageReadOptions(), &facts);
  EXPECT_EQ(facts.bits_per_channel, 16);
  ASSERT_EQ(g.width, 3);
  ASSERT_EQ(g.height, 2);
  ASSERT_EQ(g.channels, 1);
  for (size_t i = 0; i < grey.size(); ++i) EXPECT_FLOAT_EQ(g.data[i], grey[i] / 65535.f) << i;

  const std::vector<std::uint16_t> rgba = {65535, 0, 12345, 40000, 1000, 2000, 3000, 65535};
  WritePng16(dir.File("c16.png"), 2, 1, 4, rgba);
  const Image c = ReadImage(dir.File("c16.png"));
  ASSERT_EQ(c.channels, 4);
  for (size_t i = 0; i < rgba.size(); ++i) EXPECT_FLOAT_EQ(c.data[i], rgba[i] / 65535.f) << i;
  // Converted to RGB on request: the alpha dropped, the precision kept.
  const Image rgb = ReadImage(dir.File("c16.png"), 3);
  ASSERT_EQ(rgb.channels, 3);
  EXPECT_FLOAT_EQ(rgb.at(0, 0, 2), 12345 / 65535.f);
}

TEST(Image, BinaryPgmAndPpm) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("a.pgm"), std::string("P5\n# a comment\n3 1\n255\n") + char(0) + char(77) + char(255));
  const Image g = ReadImage(dir.File("a.pgm"));
  ASSERT_EQ(g.width, 3);
  ASSERT_EQ(g.channels, 1);
  EXPECT_FLOAT_EQ(g.data[0], 0.f);
  EXPECT_FLOAT_EQ(g.data[1], 77 / 255.f);
  EXPECT_FLOAT_EQ(g.data[2], 1.f);

  // 16-bit PGM: big-endian samples 0x3039 = 12345 and 0xFFFF.
  WriteFileAtomic(dir.File("b.pgm"), std::string("P5 2 1 65535\n") + "\x30\x39\xff\xff");
  ImageFileFacts facts;
  const Image g16 = ReadImage(dir.File("b.pgm"), ImageReadOptions(), &facts);
  EXPECT_EQ(facts.bits_per_channel, 16);
  EXPECT_FLOAT_EQ(g16.data[0], 12345 / 65535.f);
  EXPECT_FLOAT_EQ(g16.data[1], 1.f);

  WriteFileAtomic(dir.File("c.ppm"), std::string("P6\n1 1\n255\n") + char(255) + char(128) + char(0));
  const Image rgb = ReadImage(dir.File("c.ppm"));
  ASSERT_EQ(rgb.channels, 3);
  EXPECT_FLOAT_EQ(rgb.data[1], 128 / 255.f);
  int w = 0, h = 0, c = 0;
  ReadImageSize(dir.File("c.ppm"), &w, &h, &c);
  EXPECT_EQ(w, 1);
  EXPECT_EQ(c, 3);

  // Fewer samples than the header promises.
  WriteFileAtomic(dir.File("short.pgm"), std::string("P5\n4 4\n255\n") + "abc");
  EXPECT_NE(InputErrorOf([&] { ReadImage(dir.File("short.pgm")); }).find("short.pgm"), std::string::npos);
}

// A posing run holds its photos packed (the files' integers): unpacked they must be the floats
// ReadImage gave, bit for bit, for 8- and 16-bit PNGs and PNMs alike.
TEST(Image, PackedImagesGiveBackTheFloatsReadFromTheFile) {
  ScopedTempDir dir;
  const std::vector<std::uint16_t> grey16 = {0, 1, 257, 12345, 32768, 65535};
  WritePng16(dir.File("g16.png"), 3, 2, 1, grey16);
  Image rgb8(4, 3, 3);
  for (size_t i = 0; i < rgb8.data.size(); ++i) rgb8.data[i] = static_cast<float>((i * 37) % 256) / 255.f;
  WriteImage(dir.File("c8.png"), rgb8);
  WriteFileAtomic(dir.File("a.pgm"), std::string("P5 3 1 255\n") + char(0) + char(77) + char(255));
  WriteFileAtomic(dir.File("b.pgm"), std::string("P5 2 1 65535\n") + "\x30\x39\xff\xff");
  for (const std::string name : {"g16.png", "c8.png", "a.pgm", "b.pgm"}) {
    ImageFileFacts facts;
    const Image im = ReadImage(dir.File(name), ImageReadOptions(), &facts);
    const PackedImage packed = PackImage(im, facts.bits_per_channel);
    EXPECT_EQ(packed.data.size(), im.data.size() * facts.bits_per_channel / 8) << name;
    const Image back = UnpackImage(packed);
    ASSERT_EQ(back.width, im.width);
    ASSERT_EQ(back.channels, im.channels);
    for (size_t i = 0; i < im.data.size(); ++i) ASSERT_EQ(back.data[i], im.data[i]) << name << " " << i;
    EXPECT_EQ(packed.at(im.width - 1, im.height - 1, im.channels - 1), im.data.back()) << name;
  }
  // A float image between the levels is rounded to the nearest, out-of-range values clamped.
  Image odd(2, 1, 1);
  odd.data = {0.3f / 255.f, 2.f};
  const PackedImage p8 = PackImage(odd, 8);
  EXPECT_EQ(p8.data[0], 0);
  EXPECT_EQ(p8.data[1], 255);
  EXPECT_THROW(PackImage(odd, 12), std::invalid_argument);
}

TEST(Image, TruncatedAndCorruptJpegsAreInputErrors) {
  ScopedTempDir dir;
  const std::string jpeg = EncodeImage(TestCard(), ".jpg", "card.jpg");
  // Cut short in its image data: stb alone would return a half-grey picture.
  WriteFileAtomic(dir.File("cut.jpg"), jpeg.substr(0, jpeg.size() * 2 / 3));
  const std::string cut = InputErrorOf([&] { ReadImage(dir.File("cut.jpg")); });
  EXPECT_NE(cut.find("cut.jpg"), std::string::npos) << cut;
  EXPECT_NE(cut.find("end-of-image"), std::string::npos) << cut;
  // Cut inside its headers.
  WriteFileAtomic(dir.File("head.jpg"), jpeg.substr(0, 30));
  EXPECT_NE(InputErrorOf([&] { ReadImage(dir.File("head.jpg")); }).find("head.jpg"), std::string::npos);
  // Headers overwritten with noise after the SOI marker.
  std::string noisy = jpeg;
  for (size_t i = 2; i < 200 && i < noisy.size(); ++i) noisy[i] = char((i * 73) & 0xFF);
  WriteFileAtomic(dir.File("noise.jpg"), noisy);
  EXPECT_NE(InputErrorOf([&] { ReadImage(dir.File("noise.jpg")); }).find("noise.jpg"), std::string::npos);
  // A scan using an AC table the file never defines (a fuzzer finding: stb decoded it from
  // uninitialised memory and crashed). stb writes the standard tables; the chroma AC one (class 1,
  // id 1) is turned into a second chroma DC one (class 0, id 1).
  std::string undefined = jpeg;
  const size_t ac1 = undefined.find(std::string("\x11\x00\x02\x01\x02\x04\x04\x03", 8));
  ASSERT_NE(ac1, std::string::npos);
  undefined[ac1] = '\x01';
  WriteFileAtomic(dir.File("undefined.jpg"), undefined);
  const std::string tables = InputErrorOf([&] { ReadImage(dir.File("undefined.jpg")); });
  EXPECT_NE(tables.find("undefined.jpg: JPEG scan at byte"), std::string::npos) << tables;
  // A frame header claiming 16000 x 16000 pixels (within the pixel limit) in a few kB: refused by
  // its size before stb decodes it into 256 M pixels of filler (a fuzzer finding).
  std::string claimed = jpeg;
  const size_t sof = claimed.find(std::string("\xFF\xC0", 2));
  ASSERT_NE(sof, std::string::npos);
  for (size_t off : {sof + 5, sof + 7}) claimed[off] = '\x3E', claimed[off + 1] = '\x80';  // 16000, big-endian
  WriteFileAtomic(dir.File("claimed.jpg"), claimed);
  const std::string size = InputErrorOf([&] { ReadImage(dir.File("claimed.jpg")); });
  EXPECT_NE(size.find("claimed.jpg: size: expected at most 1024 pixels per byte of a JPEG, header says 16000x16000"),
            std::string::npos)
      << size;
  // The complete file still reads.
  WriteFileAtomic(dir.File("card.jpg"), jpeg);
  EXPECT_EQ(Corners(ReadImage(dir.File("card.jpg"))), "rbgg");
}

TEST(Image, ApplyExifOrientationRefusesOtherValues) {
  EXPECT_THROW(ApplyExifOrientation(Image(2, 2, 1), 0), std::invalid_argument);
  EXPECT_THROW(ApplyExifOrientation(Image(2, 2, 1), 9), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
