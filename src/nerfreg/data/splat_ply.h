#pragma once
// 3D Gaussian splats in the PLY layout of the INRIA 3DGS code (gaussian-splatting's
// GaussianModel.save_ply), which most splat tools read and write: one "vertex" element whose
// float properties are, per Gaussian,
//   x y z                 centre
//   nx ny nz              (optional; INRIA writes zeros) a normal
//   f_dc_0..2             the degree-0 SH coefficient per colour channel
//   f_rest_0..M-1         the SH coefficients of degrees 1..D, M = 3 ((D + 1)^2 - 1): 0, 9, 24 or 45,
//                         channel-major (f_rest_{c (K - 1) + k - 1} is channel c's coefficient k)
//   opacity               logit of the opacity
//   scale_0..2            log of the standard deviations along the Gaussian's axes
//   rot_0..3              the axes' rotation as a quaternion w x y z, not normalised
// Any other scalar property is kept (Splats::extras) and written back in its own type.
//
// The reader has its own strict checks (the Open3D-bound ply_check.h follows rply; this file is
// read by us alone): "format ascii 1.0" or "format binary_little_endian 1.0", the vertex element
// first, every property above of type float, finite values, a non-zero quaternion, log scales
// within [-kMaxLogScale, kMaxLogScale], centres within 1e7, normals, SH coefficients and quaternion
// components within 1e6. A header claiming more vertices than the
// file's bytes can hold is refused before anything is allocated. Every failure is an InputError
// "FILE: FIELD: expected ...", FIELD naming the header line, property or vertex ("vertex[17].opacity").
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace nerfreg {

// Bounds on what a splat file may hold (checked on reading): exp(40) overflows nothing we compute.
constexpr double kMaxLogScale = 40.0;
constexpr double kMaxSplatCoordinate = 1e7;
constexpr double kMaxSplatValue = 1e6;  // |normal|, |SH coefficient|, |quaternion component|

// Number of SH coefficients per channel for a degree: (degree + 1)^2.
inline int ShCoefficientCount(int degree) { return (degree + 1) * (degree + 1); }

// A scalar vertex property the format does not name, kept as read.
struct SplatExtraProperty {
  std::string name;
  std::string type;            // the PLY type as written in the header ("uchar", "float32", ...)
  std::vector<double> values;  // [N]
};

struct Splats {
  int sh_degree = 0;           // 0..3
  Eigen::Matrix3Xf position;   // [3, N]
  Eigen::Matrix3Xf normal;     // [3, N], or [3, 0] when the file has no nx ny nz
  Eigen::Matrix3Xf f_dc;       // [3, N]
  Eigen::MatrixXf f_rest;      // [3 ((D + 1)^2 - 1), N], the file's channel-major order
  Eigen::VectorXf opacity;     // [N] logit
  Eigen::Matrix3Xf log_scale;  // [3, N]
  Eigen::Matrix4Xf rotation;   // [4, N] (w, x, y, z), as stored (not normalised)
  std::vector<SplatExtraProperty> extras;

  std::int64_t size() const { return position.cols(); }
  bool has_normals() const { return normal.cols() > 0; }
  // Resizes every array to n splats of degree `sh_degree` (contents undefined; extras cleared).
  void Resize(std::int64_t n, int degree, bool normals);
  // Throws std::invalid_argument when the arrays disagree in size (a bug, not bad input).
  void CheckShapes() const;
};

// Reads a splat PLY. Throws InputError naming `path` (see the header comment).
Splats ReadSplatPly(const std::string& path);
// The same from the file's bytes; `source` names it in errors.
Splats ParseSplatPly(const std::string& bytes, const std::string& source);

// Whether the file is a PLY whose first element carries splat properties (f_dc_0, opacity, rot_0):
// how `reg register` and `reg apply` tell splats from point clouds and meshes. Reads the header
// only; false for anything that is not a PLY.
bool IsSplatPly(const std::string& path);

// The file's bytes: binary little-endian (or ASCII with `ascii`), floats written so they read back
// bit-exact.
std::string SerializeSplatPly(const Splats& splats, bool ascii = false);
// Writes atomically (util/file_util.h).
void WriteSplatPly(const Splats& splats, const std::string& path, bool ascii = false);

}  // namespace nerfreg
