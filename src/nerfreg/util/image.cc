#include "nerfreg/util/image.h"

#include <algorithm>
#include <cmath>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

namespace nerfreg {

namespace {

// stb_image trusts PNG chunk lengths and allocates them before reading (a 100-byte file claiming
// a 4 GB IDAT chunk asks for 4 GB; found by fuzzing). Walk the chunks first: every chunk must fit
// in the file.
void CheckPngChunks(const std::string& bytes, const std::string& path) {
  static const char kSignature[] = "\x89PNG\r\n\x1a\n";
  if (bytes.size() < 8 || bytes.compare(0, 8, kSignature, 8) != 0) return;  // not a PNG
  size_t pos = 8;
  while (pos + 8 <= bytes.size()) {
    const auto* u = reinterpret_cast<const unsigned char*>(bytes.data() + pos);
    const std::uint64_t length = (std::uint64_t(u[0]) << 24) | (u[1] << 16) | (u[2] << 8) | u[3];
    if (length > bytes.size() - pos - 8) {
      ThrowInputError(path, "PNG chunk at byte " + std::to_string(pos),
                      "a chunk length within the file, got " + std::to_string(length));
    }
    if (bytes.compare(pos + 4, 4, "IEND") == 0) return;
    pos += 12 + length;  // length, type, data, CRC
  }
}

Image Decode(const std::string& bytes, const std::string& path, int channels, int* w, int* h, int* c) {
  if (!stbi_info_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), static_cast<int>(bytes.size()), w, h, c)) {
    ThrowInputError(path, "", std::string("a PNG or JPEG image (") + stbi_failure_reason() + ")");
  }
  if (*w <= 0 || *h <= 0 || static_cast<std::int64_t>(*w) * *h > kMaxImagePixels) {
    ThrowInputError(path, "size",
                    "at most " + std::to_string(kMaxImagePixels) + " pixels, header says " + std::to_string(*w) + "x" +
                        std::to_string(*h));
  }
  if (channels < 0) return Image();  // size only
  CheckPngChunks(bytes, path);
  unsigned char* pixels = stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()),
                                                static_cast<int>(bytes.size()), w, h, c, channels);
  if (pixels == nullptr) {
    ThrowInputError(path, "", std::string("a decodable PNG or JPEG (") + stbi_failure_reason() + ")");
  }
  const int out_c = channels == 0 ? *c : channels;
  Image image(*w, *h, out_c);
  for (size_t i = 0; i < image.data.size(); ++i) image.data[i] = pixels[i] / 255.f;
  stbi_image_free(pixels);
  return image;
}

// Largest image file read (a 16384^2 RGBA PNG compresses far below this).
constexpr std::int64_t kMaxImageFileBytes = std::int64_t(1) << 30;

}  // namespace

void ReadImageSize(const std::string& path, int* width, int* height, int* channels) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing image file");
  // Only the header is needed: stbi_info reads a few hundred bytes from the file.
  if (!stbi_info(path.c_str(), width, height, channels)) {
    ThrowInputError(path, "", std::string("a PNG or JPEG image (") + stbi_failure_reason() + ")");
  }
  if (*width <= 0 || *height <= 0 || static_cast<std::int64_t>(*width) * *height > kMaxImagePixels) {
    ThrowInputError(path, "size",
                    "at most " + std::to_string(kMaxImagePixels) + " pixels, header says " + std::to_string(*width) +
                        "x" + std::to_string(*height));
  }
}

Image ReadImage(const std::string& path, int channels) {
  if (channels != 0 && channels != 1 && channels != 3 && channels != 4) {
    throw std::invalid_argument("ReadImage: channels must be 0, 1, 3 or 4");
  }
  if (!FileExists(path)) ThrowInputError(path, "", "an existing image file");
  const std::string bytes = ReadFileToString(path, kMaxImageFileBytes);
  int w = 0, h = 0, c = 0;
  return Decode(bytes, path, channels, &w, &h, &c);
}

std::string EncodeImage(const Image& image, const std::string& ext, const std::string& name, int jpeg_quality) {
  if (image.empty() || image.width <= 0 || image.height <= 0 ||
      image.data.size() != static_cast<size_t>(image.width) * image.height * image.channels) {
    throw std::invalid_argument("WriteImage: inconsistent image for " + name);
  }
  std::vector<unsigned char> bytes(image.data.size());
  for (size_t i = 0; i < bytes.size(); ++i) {
    const float v = std::isfinite(image.data[i]) ? image.data[i] : 0.f;
    bytes[i] = static_cast<unsigned char>(std::lround(std::clamp(v, 0.f, 1.f) * 255.f));
  }
  std::string encoded;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
  };
  int ok = 0;
  if (ext == ".png") {
    ok = stbi_write_png_to_func(append, &encoded, image.width, image.height, image.channels, bytes.data(),
                                image.width * image.channels);
  } else if (ext == ".jpg" || ext == ".jpeg") {
    ok = stbi_write_jpg_to_func(append, &encoded, image.width, image.height, image.channels, bytes.data(),
                                std::clamp(jpeg_quality, 1, 100));
  } else {
    ThrowInputError(name, "extension", ".png, .jpg or .jpeg");
  }
  if (!ok || encoded.empty()) throw std::runtime_error("WriteImage: could not encode " + name);
  return encoded;
}

void WriteImage(const std::string& path, const Image& image, int jpeg_quality) {
  // Encoded in memory, then written by WriteFileAtomic: stb's own file writer ignores a failed
  // fwrite (a full disk left truncated PNGs that reported success).
  WriteFileAtomic(path, EncodeImage(image, LowerExtension(path), path, jpeg_quality));
}

Image CompositeOver(const Image& rgba, float r, float g, float b) {
  if (rgba.channels != 4) throw std::invalid_argument("CompositeOver: expects RGBA");
  Image out(rgba.width, rgba.height, 3);
  const float bg[3] = {r, g, b};
  const size_t n = static_cast<size_t>(rgba.width) * rgba.height;
  for (size_t i = 0; i < n; ++i) {
    const float a = rgba.data[i * 4 + 3];
    for (int c = 0; c < 3; ++c) out.data[i * 3 + c] = rgba.data[i * 4 + c] * a + bg[c] * (1 - a);
  }
  return out;
}

Image NormalizeForDisplay(const Image& m, float lo, float hi) {
  if (m.channels != 1) throw std::invalid_argument("NormalizeForDisplay: expects one channel");
  Image out(m.width, m.height, 1);
  const float scale = hi > lo ? 1.f / (hi - lo) : 0.f;
  for (size_t i = 0; i < m.data.size(); ++i) {
    const float v = m.data[i];
    out.data[i] = std::isfinite(v) ? std::clamp((v - lo) * scale, 0.f, 1.f) : 0.f;
  }
  return out;
}

Image ContactSheet(const std::vector<Image>& images, int columns) {
  if (images.empty() || columns <= 0) throw std::invalid_argument("ContactSheet: no images or columns");
  int cw = 0, ch = 0;
  for (const auto& im : images) {
    cw = std::max(cw, im.width);
    ch = std::max(ch, im.height);
  }
  const int gap = 2, n = static_cast<int>(images.size());
  const int cols = std::min(columns, n), rows = (n + cols - 1) / cols;
  Image sheet(cols * (cw + gap) - gap, rows * (ch + gap) - gap, 3, 1.f);
  for (int k = 0; k < n; ++k) {
    const Image& im = images[k];
    const int ox = (k % cols) * (cw + gap), oy = (k / cols) * (ch + gap);
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x) {
        const float checker = ((x / 8 + y / 8) % 2) ? 0.8f : 0.6f;
        const float a = im.channels == 4 ? im.at(x, y, 3) : 1.f;
        for (int c = 0; c < 3; ++c) {
          const float v = im.at(x, y, im.channels >= 3 ? c : 0);
          sheet.at(ox + x, oy + y, c) = v * a + checker * (1 - a);
        }
      }
  }
  return sheet;
}

}  // namespace nerfreg
