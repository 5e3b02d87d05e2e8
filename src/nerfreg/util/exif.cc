#include "nerfreg/util/exif.h"

#include <libexif/exif-data.h>
#include <libexif/exif-log.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

namespace {

// Bytes read first by ReadExif: the EXIF segment comes before the image data, and APP segments are
// at most 64 KiB each. A file whose image data starts later is read whole.
constexpr std::size_t kExifPrefixBytes = std::size_t(1) << 18;
constexpr std::int64_t kMaxExifFileBytes = std::int64_t(1) << 30;

// The payload ("Exif\0\0" + TIFF data) of a JPEG's APP1 EXIF segment, found by walking the marker
// segments from SOI to the image data; empty when there is none. *ran_out: the bytes ended first.
std::string_view FindExifSegment(const std::string& bytes, bool* ran_out) {
  *ran_out = false;
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t n = bytes.size();
  if (n < 4 || u[0] != 0xFF || u[1] != 0xD8) return {};  // not a JPEG
  std::size_t pos = 2;
  while (true) {
    if (pos >= n) break;
    if (u[pos] != 0xFF) return {};  // not a marker: malformed, left to the decoder
    while (pos < n && u[pos] == 0xFF) ++pos;
    if (pos >= n) break;
    const unsigned marker = u[pos++];
    if (marker == 0xD9 || marker == 0xDA) return {};                     // EOI, SOS: no EXIF before the image
    if ((marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) continue;  // no length
    if (pos + 2 > n) break;
    const std::size_t length = (std::size_t(u[pos]) << 8) | u[pos + 1];
    if (length < 2) return {};
    if (pos + length > n) break;
    if (marker == 0xE1 && length >= 8 && std::memcmp(u + pos + 2, "Exif\0\0", 6) == 0) {
      return std::string_view(bytes.data() + pos + 2, length - 2);
    }
    pos += length;
  }
  *ran_out = true;
  return {};
}

std::string ReadPrefix(const std::string& path, std::size_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError(path, "", "a readable file");
  std::string bytes(max_bytes, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(max_bytes));
  bytes.resize(static_cast<std::size_t>(in.gcount()));
  return bytes;
}

// libexif reports through a log; a corrupt-data or out-of-memory message outside the maker notes
// (vendor blocks nerfreg does not read, often malformed in real photos) marks the block corrupt.
struct LogState {
  bool corrupt = false;
  std::string first_message;
};

void OnExifLog(ExifLog*, ExifLogCode code, const char* domain, const char* format, va_list args, void* data) {
  if (code != EXIF_LOG_CODE_CORRUPT_DATA && code != EXIF_LOG_CODE_NO_MEMORY) return;
  if (domain != nullptr && std::strncmp(domain, "ExifMnote", 9) == 0) return;
  auto* state = static_cast<LogState*>(data);
  if (!state->corrupt) {
    char message[256];
    std::vsnprintf(message, sizeof(message), format, args);
    state->first_message = message;
  }
  state->corrupt = true;
}

// Owns the libexif objects of one read.
struct ExifHandles {
  ExifData* data = exif_data_new();
  ExifLog* log = exif_log_new();
  ~ExifHandles() {
    if (data != nullptr) exif_data_unref(data);
    if (log != nullptr) exif_log_unref(log);
  }
};

// One value of an entry as a double: the first component of a (signed) rational, short or long.
std::optional<double> Number(const ExifEntry* e, ExifByteOrder order) {
  if (e == nullptr || e->data == nullptr || e->components < 1) return std::nullopt;
  const unsigned size = exif_format_get_size(e->format);
  if (size == 0 || e->size < size) return std::nullopt;
  switch (e->format) {
    case EXIF_FORMAT_RATIONAL: {
      const ExifRational r = exif_get_rational(e->data, order);
      if (r.denominator == 0) return std::nullopt;
      return double(r.numerator) / double(r.denominator);
    }
    case EXIF_FORMAT_SRATIONAL: {
      const ExifSRational r = exif_get_srational(e->data, order);
      if (r.denominator == 0) return std::nullopt;
      return double(r.numerator) / double(r.denominator);
    }
    case EXIF_FORMAT_SHORT:
      return double(exif_get_short(e->data, order));
    case EXIF_FORMAT_SSHORT:
      return double(exif_get_sshort(e->data, order));
    case EXIF_FORMAT_LONG:
      return double(exif_get_long(e->data, order));
    case EXIF_FORMAT_SLONG:
      return double(exif_get_slong(e->data, order));
    default:
      return std::nullopt;
  }
}

std::string Text(const ExifEntry* e) {
  if (e == nullptr || e->data == nullptr || e->format != EXIF_FORMAT_ASCII) return "";
  std::string s(reinterpret_cast<const char*>(e->data), e->size);
  s = s.substr(0, s.find('\0'));
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.pop_back();
  return s;
}

std::optional<double> PixelsPerMm(double per_unit, int unit) {
  switch (unit) {
    case 2:
      return per_unit / 25.4;  // inch
    case 3:
      return per_unit / 10.0;  // cm
    case 4:
      return per_unit;  // mm (TIFF/EP)
    case 5:
      return per_unit * 1000.;  // um (TIFF/EP)
    default:
      return std::nullopt;  // 1: no absolute unit
  }
}

ExifInfo ParseExifPayload(std::string_view payload, const std::string& path) {
  ExifHandles h;
  if (h.data == nullptr || h.log == nullptr) throw std::bad_alloc();
  LogState state;
  exif_log_set_func(h.log, OnExifLog, &state);
  exif_data_log(h.data, h.log);
  // FOLLOW_SPECIFICATION would add missing "mandatory" tags with made-up defaults on load.
  exif_data_unset_option(h.data, EXIF_DATA_OPTION_FOLLOW_SPECIFICATION);
  exif_data_load_data(h.data, reinterpret_cast<const unsigned char*>(payload.data()),
                      static_cast<unsigned int>(payload.size()));
  if (state.corrupt) {
    LOG_WARN("{}: EXIF block ignored, libexif reports it corrupt ({})", path, state.first_message);
    return ExifInfo();
  }
  const ExifByteOrder order = exif_data_get_byte_order(h.data);
  ExifContent* ifd0 = h.data->ifd[EXIF_IFD_0];
  ExifContent* exif = h.data->ifd[EXIF_IFD_EXIF];
  auto get = [](ExifContent* ifd, ExifTag tag) -> ExifEntry* {
    return ifd == nullptr ? nullptr : exif_content_get_entry(ifd, tag);
  };
  ExifInfo info;
  info.has_exif = true;
  info.make = Text(get(ifd0, EXIF_TAG_MAKE));
  info.model = Text(get(ifd0, EXIF_TAG_MODEL));
  if (const auto o = Number(get(ifd0, EXIF_TAG_ORIENTATION), order)) {
    if (*o >= 1 && *o <= 8) {
      info.orientation = static_cast<int>(*o);
    } else {
      LOG_WARN("{}: EXIF Orientation {} is not 1..8; the image is read as stored", path, *o);
    }
  }
  info.focal_length_mm = Number(get(exif, EXIF_TAG_FOCAL_LENGTH), order);
  info.focal_length_35mm = Number(get(exif, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM), order);
  info.focal_plane_x_resolution = Number(get(exif, EXIF_TAG_FOCAL_PLANE_X_RESOLUTION), order);
  if (const auto unit = Number(get(exif, EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT), order)) {
    info.focal_plane_resolution_unit = static_cast<int>(*unit);
  }
  if (info.focal_plane_x_resolution) {
    info.focal_plane_x_pixels_per_mm = PixelsPerMm(*info.focal_plane_x_resolution, info.focal_plane_resolution_unit);
  }
  auto dimension = [&](ExifTag tag) -> std::optional<int> {
    const auto v = Number(get(exif, tag), order);
    if (!v || *v < 1 || *v > 1e6) return std::nullopt;
    return static_cast<int>(*v);
  };
  info.pixel_x_dimension = dimension(EXIF_TAG_PIXEL_X_DIMENSION);
  info.pixel_y_dimension = dimension(EXIF_TAG_PIXEL_Y_DIMENSION);
  return info;
}

double FieldOfViewDeg(double focal_px, double size_px) {
  return 2.0 * std::atan(0.5 * size_px / focal_px) * 180.0 / M_PI;
}

}  // namespace

ExifInfo ReadExifFromBytes(const std::string& bytes, const std::string& path) {
  bool ran_out = false;
  const std::string_view payload = FindExifSegment(bytes, &ran_out);
  if (payload.empty()) return ExifInfo();
  return ParseExifPayload(payload, path);
}

ExifInfo ReadExif(const std::string& path) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing image file");
  std::string bytes = ReadPrefix(path, kExifPrefixBytes);
  bool ran_out = false;
  FindExifSegment(bytes, &ran_out);
  if (ran_out && bytes.size() == kExifPrefixBytes) bytes = ReadFileToString(path, kMaxExifFileBytes);
  return ReadExifFromBytes(bytes, path);
}

FocalPrior FocalPriorFromExif(const ExifInfo& exif, int width, int height, const std::string& path) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("FocalPriorFromExif: non-positive image size");
  const double max_side = std::max(width, height);
  // A route's focal is kept when its field of view across the long side is 1..170 degrees.
  auto plausible = [&](double focal_px, const char* what) {
    const double fov = FieldOfViewDeg(focal_px, max_side);
    if (std::isfinite(focal_px) && focal_px > 0 && fov >= 1.0 && fov <= 170.0) return true;
    LOG_WARN(
        "{}: EXIF {} gives a focal of {:.4g} px, a field of view of {:.4g} deg across {} px "
        "(expected 1..170); ignored",
        path, what, focal_px, fov, max_side);
    return false;
  };

  if (exif.focal_length_mm) {
    const double f_mm = *exif.focal_length_mm;
    if (!(f_mm > 0.5 && f_mm < 5000.0)) {
      LOG_WARN("{}: EXIF FocalLength {} mm is outside (0.5, 5000); ignored", path, f_mm);
    } else if (exif.focal_plane_x_pixels_per_mm) {
      const double per_mm = *exif.focal_plane_x_pixels_per_mm;
      if (!(std::isfinite(per_mm) && per_mm > 0)) {
        LOG_WARN("{}: EXIF FocalPlaneXResolution {} pixels/mm is not positive; ignored", path, per_mm);
      } else {
        const double stored_side = exif.pixel_x_dimension && exif.pixel_y_dimension
                                       ? std::max(*exif.pixel_x_dimension, *exif.pixel_y_dimension)
                                       : max_side;
        const double sensor_mm = stored_side / per_mm;
        const double focal_px = f_mm / sensor_mm * max_side;
        if (plausible(focal_px, "FocalLength over sensor width")) return {focal_px, "exif-sensor"};
      }
    }
  }
  if (exif.focal_length_35mm) {
    const double f35 = *exif.focal_length_35mm;
    if (!(f35 >= 8.0 && f35 <= 5000.0)) {
      LOG_WARN("{}: EXIF FocalLengthIn35mmFilm {} mm is outside [8, 5000]; ignored", path, f35);
    } else {
      const double focal_px = f35 / 36.0 * max_side;
      if (plausible(focal_px, "FocalLengthIn35mmFilm")) return {focal_px, "exif-35mm"};
    }
  }
  return {1.2 * max_side, "image-size"};
}

}  // namespace nerfreg
