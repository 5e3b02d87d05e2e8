#include "nerfreg/util/image.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

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

// The formats ReadImage decodes, as its errors name them.
constexpr const char* kReadFormats = "a PNG, JPEG or binary PGM/PPM image";
constexpr const char* kDecodableFormats = "a decodable PNG, JPEG or binary PGM/PPM image";

bool IsJpeg(const std::string& bytes) {
  return bytes.size() >= 3 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
         static_cast<unsigned char>(bytes[1]) == 0xD8 && static_cast<unsigned char>(bytes[2]) == 0xFF;
}

// Checks a JPEG's structure before stb_image (2.27) decodes it:
// - it decodes a JPEG cut short as if the rest were zeros (a half-grey photo, no error): the
//   end-of-image marker must come before the bytes end;
// - it decodes a scan with a Huffman or quantisation table the file never defined from
//   uninitialised memory (a wild read, found by fuzzing): each scan's tables must come before it.
// Walks the marker segments and the entropy-coded data after each SOS; stray bytes between
// segments are skipped, as libjpeg does. Malformed tables themselves are left to stb, which checks
// them.
void CheckJpegStructure(const std::string& bytes, const std::string& path) {
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  bool huffman[2][4] = {};  // [DC 0 / AC 1][table id] defined
  bool quant[4] = {};
  std::vector<int> frame_quant;  // the frame's components' quantisation table ids
  bool progressive = false;
  size_t pos = 2;  // after SOI
  while (pos < n) {
    if (u[pos] != 0xFF) {
      ++pos;
      continue;
    }
    while (pos < n && u[pos] == 0xFF) ++pos;
    if (pos >= n) break;
    const unsigned marker = u[pos++];
    if (marker == 0xD9) return;                                          // EOI
    if ((marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) continue;  // no length
    if (pos + 2 > n) break;
    const size_t length = (size_t(u[pos]) << 8) | u[pos + 1];
    if (length < 2) ThrowInputError(path, "JPEG segment at byte " + std::to_string(pos - 2), "a length >= 2");
    if (pos + length > n) break;
    const size_t body = pos + 2, body_end = pos + length;
    if (marker == 0xC4) {  // DHT: class/id, 16 counts, the values
      for (size_t p = body; p + 17 <= body_end;) {
        const int table_class = u[p] >> 4, id = u[p] & 15;
        size_t count = 0;
        for (int k = 1; k <= 16; ++k) count += u[p + k];
        if (table_class <= 1 && id <= 3) huffman[table_class][id] = true;
        p += 17 + count;
      }
    } else if (marker == 0xDB) {  // DQT: precision/id, 64 values of 8 or 16 bits
      for (size_t p = body; p < body_end;) {
        if ((u[p] & 15) <= 3) quant[u[p] & 15] = true;
        p += 1 + ((u[p] >> 4) ? 128 : 64);
      }
    } else if (marker >= 0xC0 && marker <= 0xC2 && length >= 8) {  // SOF0..2: 3 bytes a component
      progressive = marker == 0xC2;
      frame_quant.clear();
      for (size_t p = body + 6; p + 3 <= body_end && frame_quant.size() < u[body + 5]; p += 3) {
        frame_quant.push_back(u[p + 2] & 15);
      }
    } else if (marker == 0xDA && length >= 3) {  // SOS: components (id, DC/AC tables), Ss, Se, A
      const size_t components = u[body];
      const size_t ss_at = body + 1 + 2 * components;
      const int spectral_start = ss_at < body_end ? u[ss_at] : 0;
      bool defined = true;
      for (size_t k = 0; k < components && body + 2 + 2 * k < body_end; ++k) {
        const int dc = u[body + 2 + 2 * k] >> 4, ac = u[body + 2 + 2 * k] & 15;
        if (dc > 3 || ac > 3) continue;  // stb refuses these itself
        if (!progressive || spectral_start == 0) defined &= huffman[0][dc];
        if (!progressive || spectral_start > 0) defined &= huffman[1][ac];
      }
      for (int q : frame_quant) defined &= q <= 3 && quant[q];
      if (!defined) {
        ThrowInputError(path, "JPEG scan at byte " + std::to_string(pos - 2),
                        "its Huffman and quantisation tables defined before it");
      }
    }
    pos += length;
    if (marker != 0xDA) continue;
    // Entropy-coded data: ends at a marker other than a stuffed 0xFF00 or a restart marker.
    while (pos + 1 < n) {
      if (u[pos] == 0xFF && u[pos + 1] != 0x00 && u[pos + 1] != 0xFF && !(u[pos + 1] >= 0xD0 && u[pos + 1] <= 0xD7)) {
        break;
      }
      ++pos;
    }
  }
  ThrowInputError(path, "", "a complete JPEG (the file ends before its end-of-image marker: truncated?)");
}

void CheckPixelCount(std::int64_t w, std::int64_t h, const std::string& path) {
  if (w <= 0 || h <= 0 || w > kMaxImagePixels || h > kMaxImagePixels || w * h > kMaxImagePixels) {
    ThrowInputError(path, "size",
                    "at most " + std::to_string(kMaxImagePixels) + " pixels, header says " + std::to_string(w) + "x" +
                        std::to_string(h));
  }
}

// Binary PGM / PPM (P5 / P6), read here rather than by stb_image 2.27, which reads 16-bit samples
// in the machine's byte order (PNM's is big-endian), leaves the pixels of a short file
// uninitialised, and does not scale a maxval other than 255 or 65535.
bool IsPnm(const std::string& bytes) {
  return bytes.size() >= 2 && bytes[0] == 'P' && (bytes[1] == '5' || bytes[1] == '6');
}

struct PnmHeader {
  int width = 0, height = 0, channels = 0, maxval = 0;
  size_t data_offset = 0;  // first sample byte
};

PnmHeader ParsePnmHeader(const std::string& bytes, const std::string& path) {
  PnmHeader header;
  header.channels = bytes[1] == '5' ? 1 : 3;
  size_t pos = 2;
  std::int64_t fields[3] = {0, 0, 0};  // width, height, maxval
  for (auto& field : fields) {
    // Whitespace and '#' comments up to the end of their line.
    while (pos < bytes.size() && (std::isspace(static_cast<unsigned char>(bytes[pos])) || bytes[pos] == '#')) {
      if (bytes[pos] == '#') {
        while (pos < bytes.size() && bytes[pos] != '\n' && bytes[pos] != '\r') ++pos;
      } else {
        ++pos;
      }
    }
    const size_t start = pos;
    while (pos < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[pos])) && field <= 1'000'000'000) {
      field = field * 10 + (bytes[pos++] - '0');
    }
    if (pos == start || pos >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[pos]))) {
      ThrowInputError(path, "PNM header", "P5/P6, then width, height and maxval as decimal numbers");
    }
  }
  CheckPixelCount(fields[0], fields[1], path);
  if (fields[2] < 1 || fields[2] > 65535) {
    ThrowInputError(path, "PNM maxval", "1..65535, got " + std::to_string(fields[2]));
  }
  header.width = static_cast<int>(fields[0]);
  header.height = static_cast<int>(fields[1]);
  header.maxval = static_cast<int>(fields[2]);
  header.data_offset = pos + 1;  // one whitespace byte ends the header
  return header;
}

Image DecodePnm(const std::string& bytes, const std::string& path, ImageFileFacts* facts) {
  const PnmHeader h = ParsePnmHeader(bytes, path);
  const int sample_bytes = h.maxval < 256 ? 1 : 2;
  Image image(h.width, h.height, h.channels);
  const size_t needed = image.data.size() * sample_bytes;
  if (bytes.size() - h.data_offset < needed) {
    ThrowInputError(
        path, "PNM data",
        std::to_string(needed) + " sample bytes, the file has " + std::to_string(bytes.size() - h.data_offset));
  }
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data() + h.data_offset);
  // Divided, not multiplied by 1 / maxval, so that 8- and 16-bit files give PNG's values exactly
  // (PackImage relies on it).
  const float maxval = static_cast<float>(h.maxval);
  for (size_t i = 0; i < image.data.size(); ++i) {
    const int v = sample_bytes == 1 ? u[i] : (u[2 * i] << 8) | u[2 * i + 1];
    image.data[i] = static_cast<float>(std::min(v, h.maxval)) / maxval;
  }
  facts->file_channels = h.channels;
  facts->bits_per_channel = sample_bytes * 8;
  return image;
}

// Converts between 1, 3 and 4 channels as stb_image does (grey from RGB by its weights 77, 150,
// 29 / 256; alpha 1 when added, dropped when not asked for).
Image ConvertChannels(const Image& in, int channels) {
  if (channels == 0 || channels == in.channels) return in;
  Image out(in.width, in.height, channels);
  const size_t n = static_cast<size_t>(in.width) * in.height;
  for (size_t i = 0; i < n; ++i) {
    const float* p = &in.data[i * in.channels];
    float rgba[4] = {p[0], p[0], p[0], 1.f};
    if (in.channels >= 3) rgba[1] = p[1], rgba[2] = p[2];
    if (in.channels == 4) rgba[3] = p[3];
    float* q = &out.data[i * channels];
    if (channels == 1) {
      q[0] = in.channels == 1 ? p[0] : (77.f * rgba[0] + 150.f * rgba[1] + 29.f * rgba[2]) / 256.f;
    } else {
      for (int c = 0; c < channels; ++c) q[c] = rgba[c];
    }
  }
  return out;
}

// Decodes bytes to floats in [0, 1].
Image Decode(const std::string& bytes, const std::string& path, int channels, ImageFileFacts* facts) {
  if (IsPnm(bytes)) {
    Image image = DecodePnm(bytes, path, facts);
    facts->stored_width = image.width;
    facts->stored_height = image.height;
    return ConvertChannels(image, channels);
  }
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int size = static_cast<int>(bytes.size());
  int w = 0, h = 0, c = 0;
  if (!stbi_info_from_memory(data, size, &w, &h, &c)) {
    ThrowInputError(path, "", std::string(kReadFormats) + " (" + stbi_failure_reason() + ")");
  }
  CheckPixelCount(w, h, path);
  CheckPngChunks(bytes, path);
  if (IsJpeg(bytes)) {
    CheckJpegStructure(bytes, path);
    // Its entropy-coded data spends at least one bit on each 8x8 block of each component (the DC
    // code), so a JPEG describes at most 512 pixels a byte. A header that claims more is a corrupt
    // file, which stb would decode into that many pixels of filler (a fuzzer finding: 861 bytes
    // claiming 65535 x 3839, 3 GB as floats).
    constexpr std::int64_t kMaxJpegPixelsPerByte = 1024;
    if (std::int64_t(w) * h > kMaxJpegPixelsPerByte * static_cast<std::int64_t>(bytes.size())) {
      ThrowInputError(path, "size",
                      "at most " + std::to_string(kMaxJpegPixelsPerByte) + " pixels per byte of a JPEG, header says " +
                          std::to_string(w) + "x" + std::to_string(h) + " in " + std::to_string(bytes.size()) +
                          " bytes");
    }
  }
  // Grey+alpha has no Image layout of its own: RGBA.
  const int request = channels == 0 && c == 2 ? 4 : channels;
  const bool sixteen = stbi_is_16_bit_from_memory(data, size) != 0;
  void* pixels = sixteen ? static_cast<void*>(stbi_load_16_from_memory(data, size, &w, &h, &c, request))
                         : static_cast<void*>(stbi_load_from_memory(data, size, &w, &h, &c, request));
  if (pixels == nullptr) {
    ThrowInputError(path, "", std::string(kDecodableFormats) + " (" + stbi_failure_reason() + ")");
  }
  Image image(w, h, request == 0 ? c : request);
  if (sixteen) {
    const auto* p = static_cast<const std::uint16_t*>(pixels);
    for (size_t i = 0; i < image.data.size(); ++i) image.data[i] = p[i] / 65535.f;
  } else {
    const auto* p = static_cast<const stbi_uc*>(pixels);
    for (size_t i = 0; i < image.data.size(); ++i) image.data[i] = p[i] / 255.f;
  }
  stbi_image_free(pixels);
  facts->stored_width = w;
  facts->stored_height = h;
  facts->file_channels = c;
  facts->bits_per_channel = sixteen ? 16 : 8;
  return image;
}

// Largest image file read (a 16384^2 RGBA PNG compresses far below this).
constexpr std::int64_t kMaxImageFileBytes = std::int64_t(1) << 30;

}  // namespace

void ImageReadOptions::Check() const {
  if (channels != 0 && channels != 1 && channels != 3 && channels != 4) {
    throw std::invalid_argument("ReadImage: channels must be 0, 1, 3 or 4");
  }
}

void ReadImageSize(const std::string& path, int* width, int* height, int* channels) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing image file");
  // Only the header is needed: stbi_info reads a few hundred bytes from the file (and ReadExif the
  // segments before a JPEG's image data); a PNM header is read from the first 64 KiB.
  std::string head(std::size_t(1) << 16, '\0');
  {
    std::ifstream in(path, std::ios::binary);
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
  }
  if (IsPnm(head)) {
    const PnmHeader h = ParsePnmHeader(head, path);
    *width = h.width, *height = h.height, *channels = h.channels;
    return;
  }
  if (!stbi_info(path.c_str(), width, height, channels)) {
    ThrowInputError(path, "", std::string(kReadFormats) + " (" + stbi_failure_reason() + ")");
  }
  CheckPixelCount(*width, *height, path);
  if (IsJpeg(head) && ReadImageOrientation(path) >= 5) std::swap(*width, *height);
}

int ReadImageOrientation(const std::string& path) { return ReadExif(path).orientation; }

Image ReadImage(const std::string& path, const ImageReadOptions& options, ImageFileFacts* facts) {
  options.Check();
  if (!FileExists(path)) ThrowInputError(path, "", "an existing image file");
  const std::string bytes = ReadFileToString(path, kMaxImageFileBytes);
  ImageFileFacts local;
  ImageFileFacts* f = facts != nullptr ? facts : &local;
  *f = ImageFileFacts();
  Image image = Decode(bytes, path, options.channels, f);
  if (IsJpeg(bytes)) f->exif = ReadExifFromBytes(bytes, path);
  if (options.apply_exif_orientation && f->exif.orientation != 1) {
    image = ApplyExifOrientation(image, f->exif.orientation);
    f->orientation_applied = f->exif.orientation;
  }
  return image;
}

Image ReadImage(const std::string& path, int channels) {
  ImageReadOptions options;
  options.channels = channels;
  return ReadImage(path, options);
}

Image DecodeImage(const std::string& bytes, const std::string& name, int channels, std::int64_t max_pixels) {
  ImageReadOptions options;
  options.channels = channels;
  options.Check();
  if (std::int64_t(bytes.size()) > kMaxImageFileBytes) {
    ThrowInputError(name, "", "an image of at most " + std::to_string(kMaxImageFileBytes) + " bytes");
  }
  int w = 0, h = 0, c = 0;
  if (IsPnm(bytes)) {
    const PnmHeader header = ParsePnmHeader(bytes, name);
    w = header.width, h = header.height;
  } else if (!stbi_info_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), static_cast<int>(bytes.size()), &w,
                                    &h, &c)) {
    ThrowInputError(name, "", std::string(kReadFormats) + " (" + stbi_failure_reason() + ")");
  }
  if (std::int64_t(w) * h > max_pixels) {
    ThrowInputError(name, "size",
                    "at most " + std::to_string(max_pixels) + " pixels, header says " + std::to_string(w) + "x" +
                        std::to_string(h));
  }
  ImageFileFacts facts;
  return Decode(bytes, name, channels, &facts);
}

Image ApplyExifOrientation(const Image& in, int orientation) {
  if (orientation < 1 || orientation > 8) throw std::invalid_argument("ApplyExifOrientation: orientation not 1..8");
  if (orientation == 1) return in;
  const int W = in.width, H = in.height, C = in.channels;
  const bool swap = orientation >= 5;
  Image out(swap ? H : W, swap ? W : H, C);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      int sx = x, sy = y;  // the stored pixel shown at (x, y)
      switch (orientation) {
        case 2:
          sx = W - 1 - x;
          break;
        case 3:
          sx = W - 1 - x, sy = H - 1 - y;
          break;
        case 4:
          sy = H - 1 - y;
          break;
        case 5:
          sx = y, sy = x;
          break;
        case 6:
          sx = y, sy = H - 1 - x;
          break;
        case 7:
          sx = W - 1 - y, sy = H - 1 - x;
          break;
        case 8:
          sx = W - 1 - y, sy = x;
          break;
      }
      for (int c = 0; c < C; ++c) out.at(x, y, c) = in.at(sx, sy, c);
    }
  }
  return out;
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

PackedImage PackImage(const Image& image, int bits) {
  if (bits != 8 && bits != 16) throw std::invalid_argument("PackImage: bits must be 8 or 16");
  PackedImage out;
  out.width = image.width;
  out.height = image.height;
  out.channels = image.channels;
  out.bits = bits;
  const float top = bits == 8 ? 255.f : 65535.f;
  out.data.resize(image.data.size() * (bits / 8));
  // Rounded by adding a half and truncating (non-negative values): lround per sample was a third of
  // the time of reading a photo. NaN becomes 0.
  const auto level = [top](float v) { return (v > 0.f ? (v < 1.f ? v : 1.f) : 0.f) * top + 0.5f; };
  if (bits == 8) {
    for (size_t i = 0; i < image.data.size(); ++i) out.data[i] = static_cast<std::uint8_t>(level(image.data[i]));
  } else {
    for (size_t i = 0; i < image.data.size(); ++i) {
      const auto w = static_cast<std::uint16_t>(level(image.data[i]));
      std::memcpy(&out.data[2 * i], &w, 2);
    }
  }
  return out;
}

Image UnpackImage(const PackedImage& image) {
  Image out(image.width, image.height, image.channels);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < image.channels; ++c) out.at(x, y, c) = image.at(x, y, c);
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
