#pragma once
// The camera facts a photo's EXIF block carries (JPEG only), read with libexif, and the focal
// length prior they give. Structure-from-motion needs a starting focal length in pixels; a phone or
// camera photo records it, and a photo without one gets COLMAP's default guess.
#include <optional>
#include <string>

namespace nerfreg {

// What ReadExif found. Every field is absent when its tag is missing, has a zero denominator
// (EXIF's "unknown") or the wrong type; values are as recorded, not yet checked for sense
// (FocalPriorFromExif does that).
struct ExifInfo {
  bool has_exif = false;                              // the file carried an EXIF block libexif could read
  std::optional<double> focal_length_mm;              // FocalLength (0x920A), lens focal length in mm
  std::optional<double> focal_length_35mm;            // FocalLengthIn35mmFilm (0xA405), mm on a 36x24 frame
  std::optional<double> focal_plane_x_resolution;     // FocalPlaneXResolution (0xA20E), pixels per unit
  int focal_plane_resolution_unit = 2;                // FocalPlaneResolutionUnit (0xA210): 2 inch (EXIF's
                                                      // default), 3 cm, 4 mm, 5 um; 1 no unit
  std::optional<double> focal_plane_x_pixels_per_mm;  // the two above as pixels per mm (unit 2..5)
  std::optional<int> pixel_x_dimension;               // PixelXDimension (0xA002), stored width in pixels
  std::optional<int> pixel_y_dimension;               // PixelYDimension (0xA003), stored height in pixels
  std::string make;                                   // Make (0x010F), trailing spaces removed
  std::string model;                                  // Model (0x0110), trailing spaces removed
  int orientation = 1;  // Orientation (0x0112), 1..8: how the stored pixels are turned (see
                        // ApplyExifOrientation in image.h); 1 (upright) when absent or out of range
};

// Reads the EXIF block of a JPEG (the APP1 "Exif" segment before the image data). A PNG, PGM/PPM
// or a JPEG without EXIF gives an empty ExifInfo (has_exif false). A block libexif reports as
// corrupt (maker notes aside: they are not used) is treated as absent, with one LOG_WARN naming the
// file. Throws InputError only when the file is missing or unreadable.
ExifInfo ReadExif(const std::string& path);

// The same, from a file's bytes already in memory (ReadImage uses it); `path` names the file in
// warnings.
ExifInfo ReadExifFromBytes(const std::string& bytes, const std::string& path);

// A starting focal length in pixels for a photo, and where it came from.
struct FocalPrior {
  double focal_px = 0;  // pixels, for the image as decoded (upright)
  std::string source;   // "exif-sensor", "exif-35mm" or "image-size"
};

// The focal prior of a photo decoded at width x height pixels AFTER its orientation was applied
// (ReadImage's output). Only max(width, height) matters: the EXIF values describe the sensor's
// long side, which an upright portrait photo still has, turned. In order:
//  (a) "exif-sensor": FocalLength in mm over the sensor's long side in mm, the latter being the
//      stored long side (max of PixelX/YDimension when both are recorded, else max(width, height))
//      divided by FocalPlaneXResolution in pixels per mm; times max(width, height). A photo resized
//      after capture keeps the right focal when PixelX/YDimension were recorded.
//  (b) "exif-35mm": FocalLengthIn35mmFilm / 36 * max(width, height) (36 mm: the 35 mm frame's
//      long side).
//  (c) "image-size": 1.2 * max(width, height) (COLMAP's default prior, about 45 degrees across).
// An absurd value is ignored with one LOG_WARN naming `path` and the value, and the next route is
// tried: FocalLength <= 0.5 or >= 5000 mm, FocalLengthIn35mmFilm outside [8, 5000] mm, a
// non-positive or non-finite resolution, or a route whose field of view across max(width, height)
// is under 1 or over 170 degrees. Throws std::invalid_argument for a non-positive width or height.
FocalPrior FocalPriorFromExif(const ExifInfo& exif, int width, int height, const std::string& path);

}  // namespace nerfreg
