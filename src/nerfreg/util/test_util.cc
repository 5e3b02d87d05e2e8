#include "nerfreg/util/test_util.h"

#include <stdlib.h>

#include <libexif/exif-data.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>
#include <zlib.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

ScopedTempDir::ScopedTempDir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "nerfreg_test_XXXXXX").string();
  if (mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = tmpl;
}

ScopedTempDir::~ScopedTempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string InputErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

namespace {

// Adds a tag of `format` with `components` zeroed components to an IFD; returns its data.
unsigned char* AddEntry(ExifData* data, ExifIfd ifd, ExifTag tag, ExifFormat format, unsigned components) {
  ExifEntry* e = exif_entry_new();
  const unsigned size = exif_format_get_size(format) * components;
  e->data = static_cast<unsigned char*>(std::calloc(size, 1));  // freed by libexif's default allocator
  e->size = size;
  e->tag = tag;
  e->format = format;
  e->components = components;
  exif_content_add_entry(data->ifd[ifd], e);
  exif_entry_unref(e);
  return e->data;
}

}  // namespace

std::string MakeExifApp1(const TestExif& x) {
  ExifData* data = exif_data_new();
  exif_data_unset_option(data, EXIF_DATA_OPTION_FOLLOW_SPECIFICATION);
  exif_data_set_byte_order(data, EXIF_BYTE_ORDER_INTEL);
  const ExifByteOrder o = EXIF_BYTE_ORDER_INTEL;
  auto rational = [&](ExifIfd ifd, ExifTag tag, const TestRational& r) {
    exif_set_rational(AddEntry(data, ifd, tag, EXIF_FORMAT_RATIONAL, 1), o, ExifRational{r.numerator, r.denominator});
  };
  auto short_value = [&](ExifIfd ifd, ExifTag tag, std::uint16_t v) {
    exif_set_short(AddEntry(data, ifd, tag, EXIF_FORMAT_SHORT, 1), o, v);
  };
  auto text = [&](ExifIfd ifd, ExifTag tag, const std::string& s) {
    std::memcpy(AddEntry(data, ifd, tag, EXIF_FORMAT_ASCII, static_cast<unsigned>(s.size() + 1)), s.c_str(),
                s.size() + 1);
  };
  if (!x.make.empty()) text(EXIF_IFD_0, EXIF_TAG_MAKE, x.make);
  if (!x.model.empty()) text(EXIF_IFD_0, EXIF_TAG_MODEL, x.model);
  if (x.orientation) short_value(EXIF_IFD_0, EXIF_TAG_ORIENTATION, *x.orientation);
  if (x.focal_length_mm) rational(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH, *x.focal_length_mm);
  if (x.focal_length_35mm) short_value(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM, *x.focal_length_35mm);
  if (x.focal_plane_x_resolution) {
    rational(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_X_RESOLUTION, *x.focal_plane_x_resolution);
  }
  if (x.focal_plane_resolution_unit) {
    short_value(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT, *x.focal_plane_resolution_unit);
  }
  if (x.pixel_x_dimension) {
    exif_set_long(AddEntry(data, EXIF_IFD_EXIF, EXIF_TAG_PIXEL_X_DIMENSION, EXIF_FORMAT_LONG, 1), o,
                  *x.pixel_x_dimension);
  }
  if (x.pixel_y_dimension) {
    exif_set_long(AddEntry(data, EXIF_IFD_EXIF, EXIF_TAG_PIXEL_Y_DIMENSION, EXIF_FORMAT_LONG, 1), o,
                  *x.pixel_y_dimension);
  }
  unsigned char* buffer = nullptr;
  unsigned int size = 0;
  exif_data_save_data(data, &buffer, &size);
  exif_data_unref(data);
  if (buffer == nullptr || size + 2 > 0xFFFF) throw std::runtime_error("MakeExifApp1: libexif saved no block");
  const unsigned length = size + 2;
  std::string segment = {'\xFF', '\xE1', char(length >> 8), char(length & 0xFF)};
  segment.append(reinterpret_cast<const char*>(buffer), size);
  std::free(buffer);
  return segment;
}

void WriteJpegWithExif(const std::string& path, const Image& image, const TestExif& exif) {
  const std::string jpeg = EncodeImage(image, ".jpg", path, 95);
  WriteFileAtomic(path, jpeg.substr(0, 2) + MakeExifApp1(exif) + jpeg.substr(2));
}

void WritePng16(const std::string& path, int width, int height, int channels,
                const std::vector<std::uint16_t>& samples) {
  static const int kColourType[5] = {0, 0, 4, 2, 6};  // grey, grey+alpha, RGB, RGBA
  if (channels < 1 || channels > 4 || samples.size() != size_t(width) * height * channels) {
    throw std::invalid_argument("WritePng16: inconsistent samples");
  }
  auto be32 = [](std::uint32_t v) { return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)}; };
  auto chunk = [&](const std::string& type, const std::string& body) {
    const std::string typed = type + body;
    const auto crc = crc32(0, reinterpret_cast<const Bytef*>(typed.data()), static_cast<uInt>(typed.size()));
    return be32(static_cast<std::uint32_t>(body.size())) + typed + be32(static_cast<std::uint32_t>(crc));
  };
  std::string raw;  // each row: filter type 0, then big-endian samples
  for (int y = 0; y < height; ++y) {
    raw.push_back('\0');
    for (int i = 0; i < width * channels; ++i) {
      const std::uint16_t v = samples[size_t(y) * width * channels + i];
      raw.push_back(char(v >> 8));
      raw.push_back(char(v & 0xFF));
    }
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::string packed(packed_size, '\0');
  if (compress(reinterpret_cast<Bytef*>(packed.data()), &packed_size, reinterpret_cast<const Bytef*>(raw.data()),
               static_cast<uLong>(raw.size())) != Z_OK) {
    throw std::runtime_error("WritePng16: zlib compress failed");
  }
  packed.resize(packed_size);
  const std::string ihdr = be32(width) + be32(height) + std::string{char(16), char(kColourType[channels]), 0, 0, 0};
  WriteFileAtomic(
      path, std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IDAT", packed) + chunk("IEND", ""));
}

ScopedLogCapture::ScopedLogCapture()
    : stream_(std::make_shared<std::ostringstream>()), previous_(spdlog::default_logger()) {
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(*stream_);
  auto logger = std::make_shared<spdlog::logger>("capture", sink);
  logger->set_level(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

ScopedLogCapture::~ScopedLogCapture() { spdlog::set_default_logger(previous_); }

namespace {
void PutLe(std::string* out, std::uint32_t v, int bytes) {
  for (int k = 0; k < bytes; ++k) out->push_back(static_cast<char>((v >> (8 * k)) & 0xff));
}
}  // namespace

std::string MakeTestZip(const std::vector<TestZipEntry>& entries) {
  std::string out, central;
  for (const auto& e : entries) {
    std::string packed = e.data;
    if (e.deflate) {
      z_stream s;
      std::memset(&s, 0, sizeof(s));
      if (deflateInit2(&s, 9, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK)
        throw std::runtime_error("MakeTestZip: deflateInit2 failed");
      packed.assign(deflateBound(&s, e.data.size()), '\0');
      s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(e.data.data()));
      s.avail_in = static_cast<uInt>(e.data.size());
      s.next_out = reinterpret_cast<Bytef*>(packed.data());
      s.avail_out = static_cast<uInt>(packed.size());
      if (deflate(&s, Z_FINISH) != Z_STREAM_END) throw std::runtime_error("MakeTestZip: deflate failed");
      packed.resize(s.total_out);
      deflateEnd(&s);
    }
    const auto crc = static_cast<std::uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(e.data.data()), static_cast<uInt>(e.data.size())));
    const auto offset = static_cast<std::uint32_t>(out.size());
    const std::uint32_t method = e.deflate ? 8 : 0;
    PutLe(&out, 0x04034b50, 4);
    PutLe(&out, 20, 2);
    PutLe(&out, 0, 2);
    PutLe(&out, method, 2);
    PutLe(&out, 0, 4);  // time, date
    PutLe(&out, crc, 4);
    PutLe(&out, static_cast<std::uint32_t>(packed.size()), 4);
    PutLe(&out, static_cast<std::uint32_t>(e.data.size()), 4);
    PutLe(&out, static_cast<std::uint32_t>(e.name.size()), 2);
    PutLe(&out, 0, 2);
    out += e.name + packed;
    PutLe(&central, 0x02014b50, 4);
    PutLe(&central, 20, 2);
    PutLe(&central, 20, 2);
    PutLe(&central, 0, 2);
    PutLe(&central, method, 2);
    PutLe(&central, 0, 4);
    PutLe(&central, crc, 4);
    PutLe(&central, static_cast<std::uint32_t>(packed.size()), 4);
    PutLe(&central, static_cast<std::uint32_t>(e.data.size()), 4);
    PutLe(&central, static_cast<std::uint32_t>(e.name.size()), 2);
    PutLe(&central, 0, 2);  // extra
    PutLe(&central, 0, 2);  // comment
    PutLe(&central, 0, 2);  // disk
    PutLe(&central, 0, 2);  // internal attributes
    PutLe(&central, 0, 4);  // external attributes
    PutLe(&central, offset, 4);
    central += e.name;
  }
  const auto cd_offset = static_cast<std::uint32_t>(out.size());
  out += central;
  PutLe(&out, 0x06054b50, 4);
  PutLe(&out, 0, 4);
  PutLe(&out, static_cast<std::uint32_t>(entries.size()), 2);
  PutLe(&out, static_cast<std::uint32_t>(entries.size()), 2);
  PutLe(&out, static_cast<std::uint32_t>(central.size()), 4);
  PutLe(&out, cd_offset, 4);
  PutLe(&out, 0, 2);
  return out;
}

}  // namespace nerfreg
