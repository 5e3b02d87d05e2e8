#include "nerfreg/util/exif.h"

#include <gtest/gtest.h>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A phone-like camera: 4.25 mm lens on a sensor 5.6 mm across 4000 pixels, i.e.
// 4000 / 5.6 = 5000/7 pixels per mm = 127000/7 pixels per inch.
TestExif PhoneExif() {
  TestExif x;
  x.make = "Acme  ";
  x.model = "Pocket 7";
  x.orientation = 1;
  x.focal_length_mm = TestRational{425, 100};
  x.focal_length_35mm = 28;
  x.focal_plane_x_resolution = TestRational{127000, 7};
  x.focal_plane_resolution_unit = 2;  // inch
  x.pixel_x_dimension = 4000;
  x.pixel_y_dimension = 3000;
  return x;
}

TEST(Exif, ValuesReadBackFromAJpegWithAnExifBlock) {
  ScopedTempDir dir;
  WriteJpegWithExif(dir.File("p.jpg"), Image(64, 48, 3, 0.5f), PhoneExif());
  const ExifInfo e = ReadExif(dir.File("p.jpg"));
  EXPECT_TRUE(e.has_exif);
  EXPECT_EQ(e.make, "Acme");  // trailing spaces removed
  EXPECT_EQ(e.model, "Pocket 7");
  EXPECT_EQ(e.orientation, 1);
  ASSERT_TRUE(e.focal_length_mm);
  EXPECT_DOUBLE_EQ(*e.focal_length_mm, 4.25);
  ASSERT_TRUE(e.focal_length_35mm);
  EXPECT_DOUBLE_EQ(*e.focal_length_35mm, 28);
  ASSERT_TRUE(e.focal_plane_x_resolution);
  EXPECT_DOUBLE_EQ(*e.focal_plane_x_resolution, 127000.0 / 7);
  EXPECT_EQ(e.focal_plane_resolution_unit, 2);
  ASSERT_TRUE(e.focal_plane_x_pixels_per_mm);
  EXPECT_NEAR(*e.focal_plane_x_pixels_per_mm, 5000.0 / 7, 1e-9);
  EXPECT_EQ(e.pixel_x_dimension, 4000);
  EXPECT_EQ(e.pixel_y_dimension, 3000);
  // The image still decodes, and ReadImage reports the same block.
  ImageFileFacts facts;
  const Image im = ReadImage(dir.File("p.jpg"), ImageReadOptions(), &facts);
  EXPECT_EQ(im.width, 64);
  EXPECT_EQ(facts.exif.model, "Pocket 7");
  EXPECT_EQ(facts.orientation_applied, 1);
}

TEST(Exif, CentimetreUnitAndMissingTags) {
  ScopedTempDir dir;
  TestExif x;
  x.focal_plane_x_resolution = TestRational{2500, 1};
  x.focal_plane_resolution_unit = 3;  // cm
  WriteJpegWithExif(dir.File("p.jpg"), Image(8, 8, 3, 0.5f), x);
  const ExifInfo e = ReadExif(dir.File("p.jpg"));
  EXPECT_TRUE(e.has_exif);
  ASSERT_TRUE(e.focal_plane_x_pixels_per_mm);
  EXPECT_DOUBLE_EQ(*e.focal_plane_x_pixels_per_mm, 250.0);
  EXPECT_FALSE(e.focal_length_mm);
  EXPECT_FALSE(e.focal_length_35mm);
  EXPECT_FALSE(e.pixel_x_dimension);
  EXPECT_EQ(e.make, "");
  EXPECT_EQ(e.orientation, 1);
}

TEST(Exif, FilesWithoutExifGiveAnEmptyInfo) {
  ScopedTempDir dir;
  WriteImage(dir.File("a.png"), Image(4, 4, 3, 0.5f));
  WriteImage(dir.File("a.jpg"), Image(4, 4, 3, 0.5f));
  WriteFileAtomic(dir.File("a.pgm"), std::string("P5\n2 1\n255\n") + char(10) + char(200));
  for (const char* name : {"a.png", "a.jpg", "a.pgm"}) {
    const ExifInfo e = ReadExif(dir.File(name));
    EXPECT_FALSE(e.has_exif) << name;
    EXPECT_FALSE(e.focal_length_mm) << name;
    EXPECT_EQ(e.orientation, 1) << name;
  }
  EXPECT_THROW(ReadExif(dir.File("none.jpg")), InputError);
}

TEST(Exif, CorruptExifBlockIsIgnoredWithAWarning) {
  ScopedTempDir dir;
  std::string app1 = MakeExifApp1(PhoneExif());
  // Bytes 10..11 of the segment are the TIFF header's byte order ("II"); make it neither II nor MM.
  ASSERT_EQ(app1.substr(10, 2), "II");
  app1[10] = 'X';
  app1[11] = 'Y';
  const std::string jpeg = EncodeImage(Image(16, 8, 3, 0.5f), ".jpg", "p.jpg");
  WriteFileAtomic(dir.File("p.jpg"), jpeg.substr(0, 2) + app1 + jpeg.substr(2));
  ScopedLogCapture log;
  const ExifInfo e = ReadExif(dir.File("p.jpg"));
  EXPECT_FALSE(e.has_exif);
  EXPECT_FALSE(e.focal_length_mm);
  EXPECT_NE(log.text().find("p.jpg: EXIF block ignored"), std::string::npos) << log.text();
  // The pixels are still read.
  EXPECT_EQ(ReadImage(dir.File("p.jpg")).width, 16);
}

TEST(Exif, EntryPointingPastTheBlockDoesNotCrash) {
  // Every 4-byte window of the IFDs overwritten with a huge offset in turn: libexif must report
  // or skip, never crash; whatever it reads stays in range.
  ScopedTempDir dir;
  const std::string app1 = MakeExifApp1(PhoneExif());
  const std::string jpeg = EncodeImage(Image(8, 8, 3, 0.5f), ".jpg", "p.jpg");
  for (size_t at = 18; at + 4 <= app1.size(); at += 3) {
    std::string bad = app1;
    for (int k = 0; k < 4; ++k) bad[at + k] = '\xF0';
    const std::string path = dir.File("p" + std::to_string(at) + ".jpg");
    WriteFileAtomic(path, jpeg.substr(0, 2) + bad + jpeg.substr(2));
    ScopedLogCapture log;
    const ExifInfo e = ReadExif(path);
    EXPECT_GE(e.orientation, 1);
    EXPECT_LE(e.orientation, 8);
  }
}

TEST(FocalPrior, SensorWidthRouteComesFirst) {
  ScopedTempDir dir;
  WriteJpegWithExif(dir.File("p.jpg"), Image(64, 48, 3, 0.5f), PhoneExif());
  const ExifInfo e = ReadExif(dir.File("p.jpg"));
  // 4.25 mm over a 5.6 mm sensor, times the decoded long side (64 px; the 4000 px stored one gives
  // the sensor width): 4.25 / 5.6 * 64 = 48.5714... px.
  const FocalPrior p = FocalPriorFromExif(e, 64, 48, dir.File("p.jpg"));
  EXPECT_EQ(p.source, "exif-sensor");
  EXPECT_NEAR(p.focal_px, 4.25 / 5.6 * 64, 1e-9);
  EXPECT_NEAR(p.focal_px, 48.5714285714, 1e-6);
  // Upright portrait (48 x 64): the long side, hence the focal, is unchanged.
  EXPECT_NEAR(FocalPriorFromExif(e, 48, 64, "p.jpg").focal_px, p.focal_px, 1e-12);
  // Without PixelX/YDimension the decoded long side stands for the stored one: 4.25 * 5000/7 px.
  ExifInfo no_dims = e;
  no_dims.pixel_x_dimension.reset();
  const FocalPrior q = FocalPriorFromExif(no_dims, 64, 48, "p.jpg");
  EXPECT_EQ(q.source, "exif-sensor");
  EXPECT_NEAR(q.focal_px, 4.25 * 5000.0 / 7, 1e-9);  // 3035.7 px: a 1.2 deg view across 64 px
}

TEST(FocalPrior, ThirtyFiveMillimetreRouteWithoutSensorResolution) {
  ScopedTempDir dir;
  TestExif x = PhoneExif();
  x.focal_plane_x_resolution.reset();
  WriteJpegWithExif(dir.File("p.jpg"), Image(64, 48, 3, 0.5f), x);
  const ExifInfo e = ReadExif(dir.File("p.jpg"));
  EXPECT_FALSE(e.focal_plane_x_pixels_per_mm);
  const FocalPrior p = FocalPriorFromExif(e, 64, 48, "p.jpg");
  EXPECT_EQ(p.source, "exif-35mm");
  EXPECT_NEAR(p.focal_px, 28.0 / 36.0 * 64, 1e-9);  // 49.78 px
}

TEST(FocalPrior, NoExifGivesTheImageSizePrior) {
  const FocalPrior p = FocalPriorFromExif(ExifInfo(), 640, 480, "a.png");
  EXPECT_EQ(p.source, "image-size");
  EXPECT_DOUBLE_EQ(p.focal_px, 768.0);
  EXPECT_THROW(FocalPriorFromExif(ExifInfo(), 0, 480, "a.png"), std::invalid_argument);
}

TEST(FocalPrior, AbsurdFocalLengthsFallBackToImageSizeWithAWarning) {
  ScopedTempDir dir;
  for (const std::uint32_t mm : {0u, 10000u}) {
    TestExif x;
    x.focal_length_mm = TestRational{mm, 1};
    x.focal_plane_x_resolution = TestRational{5000, 1};
    x.focal_plane_resolution_unit = 4;  // mm
    const std::string path = dir.File("f" + std::to_string(mm) + ".jpg");
    WriteJpegWithExif(path, Image(64, 48, 3, 0.5f), x);
    const ExifInfo e = ReadExif(path);
    ASSERT_TRUE(e.focal_length_mm);
    ScopedLogCapture log;
    const FocalPrior p = FocalPriorFromExif(e, 64, 48, path);
    EXPECT_EQ(p.source, "image-size");
    EXPECT_DOUBLE_EQ(p.focal_px, 1.2 * 64);
    EXPECT_NE(log.text().find(path + ": EXIF FocalLength " + std::to_string(mm) + " mm"), std::string::npos)
        << log.text();
  }
}

TEST(FocalPrior, AbsurdThirtyFiveMillimetreAndFieldOfViewAreIgnored) {
  ExifInfo e;
  e.has_exif = true;
  e.focal_length_35mm = 4;  // below 8 mm
  {
    ScopedLogCapture log;
    EXPECT_EQ(FocalPriorFromExif(e, 100, 50, "a.jpg").source, "image-size");
    EXPECT_NE(log.text().find("a.jpg: EXIF FocalLengthIn35mmFilm 4 mm"), std::string::npos) << log.text();
  }
  // 50 mm on a sensor of 0.5 px/mm: 25 px for 100 px across, a 127 deg view: kept.
  e.focal_length_mm = 50;
  e.focal_plane_x_pixels_per_mm = 0.5;
  EXPECT_EQ(FocalPriorFromExif(e, 100, 50, "a.jpg").source, "exif-sensor");
  // 1 mm on that sensor: 0.5 px, a 178.9 deg view: ignored, and the 35 mm value is too.
  e.focal_length_mm = 1;
  ScopedLogCapture log;
  EXPECT_EQ(FocalPriorFromExif(e, 100, 50, "a.jpg").source, "image-size");
  EXPECT_NE(log.text().find("field of view of 178.9 deg"), std::string::npos) << log.text();
}

}  // namespace
}  // namespace nerfreg
