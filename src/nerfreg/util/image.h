#pragma once
// 8-bit PNG / JPEG images in and out (stb). In memory an image is float in [0, 1], row-major,
// interleaved channels: data[(y * width + x) * channels + c], y down from the top row.
#include <cstdint>
#include <string>
#include <vector>

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

// Images larger than this many pixels are refused before decoding (a corrupt or hostile header
// could otherwise ask for tens of GB).
constexpr std::int64_t kMaxImagePixels = std::int64_t(1) << 28;  // 16384 x 16384

// Reads PNG or JPEG. `channels` 0 keeps the file's channel count; 1, 3 or 4 converts.
// Throws InputError naming the file on a missing, unreadable or oversized image.
Image ReadImage(const std::string& path, int channels = 0);

// Reads only the size. Throws like ReadImage.
void ReadImageSize(const std::string& path, int* width, int* height, int* channels);

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
