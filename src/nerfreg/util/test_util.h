#pragma once
// Helpers for tests: a fresh temporary directory per test, removed afterwards; photos with EXIF
// blocks and 16-bit PNGs written by hand; the log captured.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "nerfreg/util/image.h"

namespace spdlog {
class logger;
}

namespace nerfreg {

class ScopedTempDir {
 public:
  ScopedTempDir();
  ~ScopedTempDir();
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// Runs f and returns the message of the InputError it throws, or "" when it throws none.
std::string InputErrorOf(const std::function<void()>& f);

// An EXIF rational, numerator / denominator.
struct TestRational {
  std::uint32_t numerator = 0;
  std::uint32_t denominator = 1;
};

// The EXIF tags a test photo carries; unset ones are left out of the block.
struct TestExif {
  std::optional<TestRational> focal_length_mm;           // FocalLength
  std::optional<std::uint16_t> focal_length_35mm;        // FocalLengthIn35mmFilm
  std::optional<TestRational> focal_plane_x_resolution;  // FocalPlaneXResolution
  std::optional<std::uint16_t> focal_plane_resolution_unit;
  std::optional<std::uint32_t> pixel_x_dimension;  // PixelXDimension (LONG)
  std::optional<std::uint32_t> pixel_y_dimension;
  std::optional<std::uint16_t> orientation;
  std::string make, model;  // left out when empty
};

// The APP1 segment (marker, length, "Exif\0\0" + TIFF data) libexif builds for `exif`.
std::string MakeExifApp1(const TestExif& exif);

// Writes `image` as a JPEG (WriteImage, quality 95) with MakeExifApp1(exif) spliced in right after
// its SOI marker, where cameras put it.
void WriteJpegWithExif(const std::string& path, const Image& image, const TestExif& exif);

// Writes a 16-bit PNG (stb writes only 8 bits) built by hand with zlib: `samples` are
// [height * width * channels], channels 1 (grey), 2 (grey+alpha), 3 (RGB) or 4 (RGBA).
void WritePng16(const std::string& path, int width, int height, int channels,
                const std::vector<std::uint16_t>& samples);

// One entry of a test zip archive.
struct TestZipEntry {
  std::string name;
  std::string data;
  bool deflate = true;  // deflated (method 8), else stored (0)
};

// The bytes of a zip archive of `entries` (local headers, data, central directory, end record),
// built with zlib, so readers are tested against archives with known contents.
std::string MakeTestZip(const std::vector<TestZipEntry>& entries);

// Sends the default logger's output to a string while alive (at info level and above).
class ScopedLogCapture {
 public:
  ScopedLogCapture();
  ~ScopedLogCapture();
  std::string text() const { return stream_->str(); }

 private:
  std::shared_ptr<std::ostringstream> stream_;
  std::shared_ptr<spdlog::logger> previous_;
};

}  // namespace nerfreg
