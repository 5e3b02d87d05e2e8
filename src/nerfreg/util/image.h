#pragma once
// Images in and out (stb). Read: PNG (8 or 16 bits; grey, grey+alpha, RGB, RGBA), JPEG (turned
// upright by its EXIF Orientation), binary PGM / PPM (P5 / P6, 8 or 16 bits). Written: 8-bit PNG
// and JPEG. In memory an image is float in [0, 1] (16-bit values / 65535, 8-bit / 255), row-major,
// interleaved channels: data[(y * width + x) * channels + c], y down from the top row.
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "nerfreg/util/exif.h"

namespace nerfreg {

struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;         // 1 (grey), 3 (RGB) or 4 (RGBA)
  std::vector<float> data;  // [height * width * channels], values in [0, 1]

  Image() = default;
  Image(int w, int h, int c, float fill = 0.f)
      : width(w), height(h), channels(c), data(static_cast<size_t>(w) * h * c, fill) {}

  float& at(int x, int y, int c) { return data[(static_cast<size_t>(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const { return data[(static_cast<size_t>(y) * width + x) * channels + c]; }
  bool empty() const { return data.empty(); }
};

// v / 255.f for v = 0..255, looked up: as exact as the division, and cheaper in per-pixel loops.
struct ByteToUnitTable {
  float value[256];
  ByteToUnitTable() {
    for (int v = 0; v < 256; ++v) value[v] = static_cast<float>(v) / 255.f;
  }
};
inline const ByteToUnitTable kByteToUnit;

// An image held as its file's integers: 8 or 16 bits a channel, a quarter or half of the float
// Image's memory. A folder of photos is held this way for the whole of a posing run (500 photos of
// 1008 x 756 were 4.6 GB as float, issue 44); code that reads pixels reads them through at(), which
// returns the float ReadImage would have given (v / 255 or v / 65535), so it may take either type.
struct PackedImage {
  int width = 0;
  int height = 0;
  int channels = 0;                // as Image's
  int bits = 8;                    // 8 or 16
  std::vector<std::uint8_t> data;  // [height * width * channels * bits / 8], 16-bit values native-endian

  float at(int x, int y, int c) const {
    const size_t i = (static_cast<size_t>(y) * width + x) * channels + c;
    if (bits == 8) return kByteToUnit.value[data[i]];
    std::uint16_t v;
    std::memcpy(&v, &data[2 * i], 2);
    return static_cast<float>(v) / 65535.f;
  }
  bool empty() const { return data.empty(); }
};

// The image at `bits` (8 or 16) a channel, values clamped to [0, 1] and rounded: exact for an
// image ReadImage decoded from a file of that depth (UnpackImage(PackImage(im)) == im; a PNM's
// maxval 255 or 65535). Throws std::invalid_argument for other bits.
PackedImage PackImage(const Image& image, int bits);
Image UnpackImage(const PackedImage& image);

// Images larger than this many pixels are refused before decoding (a corrupt or hostile header
// could otherwise ask for tens of GB).
constexpr std::int64_t kMaxImagePixels = std::int64_t(1) << 28;  // 16384 x 16384

// Reads an image (the formats above, told apart by content, not extension), a JPEG turned upright
// by its EXIF Orientation. `channels` 0 keeps the file's channel count (grey+alpha becomes RGBA:
// an Image holds 1, 3 or 4); 1, 3 or 4 converts. Throws InputError naming the file on a missing,
// unreadable, oversized, corrupt or truncated image.
Image ReadImage(const std::string& path, int channels = 0);

// Decodes an image held in memory (the formats above; a JPEG's EXIF Orientation is not applied),
// e.g. a texture read out of an archive. `name` stands for it in errors. An image of more than
// `max_pixels` is refused from its header, before its pixels are allocated. Throws InputError.
Image DecodeImage(const std::string& bytes, const std::string& name, int channels = 0,
                  std::int64_t max_pixels = kMaxImagePixels);

// How the ReadImage overload below decodes.
struct ImageReadOptions {
  int channels = 0;                    // 0 keeps the file's (grey+alpha: RGBA); 1, 3 or 4 converts
  bool apply_exif_orientation = true;  // turn a JPEG upright by its EXIF Orientation; false keeps
                                       // the stored pixel order (e.g. cameras posed on it)
  void Check() const;                  // throws std::invalid_argument
};

// What the ReadImage overload below found in the file besides the pixels.
struct ImageFileFacts {
  int stored_width = 0;  // pixels as stored, before any orientation
  int stored_height = 0;
  int file_channels = 0;        // the file's channel count (2: grey+alpha)
  int bits_per_channel = 8;     // 8 or 16
  int orientation_applied = 1;  // the EXIF Orientation the returned pixels were turned by (1: none)
  ExifInfo exif;                // a JPEG's EXIF block (empty for other formats or none)
};

// ReadImage with options, also saying what it found (`facts` may be null). One read of the file
// gives the pixels and the EXIF for FocalPriorFromExif (exif.h), whose width and height are the
// returned image's.
Image ReadImage(const std::string& path, const ImageReadOptions& options, ImageFileFacts* facts = nullptr);

// Reads only the size, as ReadImage returns it: a JPEG whose EXIF Orientation is 5..8 (a quarter
// turn) has its stored width and height swapped. `channels` is the file's. Throws like ReadImage.
void ReadImageSize(const std::string& path, int* width, int* height, int* channels);

// The EXIF Orientation ReadImage applies to this file: 1..8, 1 for a file other than a JPEG or one
// without the tag. Reads only the file's EXIF. Throws InputError for a missing file.
int ReadImageOrientation(const std::string& path);

// Turns stored pixels upright for an EXIF Orientation (where the stored row 0 / column 0 belong):
// 1 as is, 2 mirrored left-right, 3 turned 180 degrees, 4 mirrored top-bottom, 5 transposed
// (mirrored about the main diagonal), 6 turned 90 degrees clockwise, 7 transversed (mirrored about
// the anti-diagonal), 8 turned 90 degrees counter-clockwise. 5..8 swap width and height. Throws
// std::invalid_argument for an orientation outside 1..8.
Image ApplyExifOrientation(const Image& stored, int orientation);

// Writes PNG (by extension .png) or JPEG (.jpg/.jpeg, quality jpeg_quality in 1..100) atomically;
// values clamped.
void WriteImage(const std::string& path, const Image& image, int jpeg_quality = 95);

// The bytes WriteImage would write, in memory (e.g. for data: URIs). `extension` is ".png",
// ".jpg" or ".jpeg"; `name` names the image in errors.
std::string EncodeImage(const Image& image, const std::string& extension, const std::string& name,
                        int jpeg_quality = 95);

// Composites RGBA over a constant background colour, returning RGB.
Image CompositeOver(const Image& rgba, float r, float g, float b);

// Maps a single-channel map to an 8-bit-friendly grey image in [0, 1] using [lo, hi]
// (e.g. depth maps for viewing); values outside are clamped, non-finite values become 0.
Image NormalizeForDisplay(const Image& single_channel, float lo, float hi);

// Tiles images (any channel count; shown as RGB, RGBA over a checkerboard) into one sheet with
// `columns` columns and a 2-pixel gap, each cell the size of the largest image.
Image ContactSheet(const std::vector<Image>& images, int columns);

}  // namespace nerfreg
