#include "nerfreg/data/splat_ply.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "nerfreg/data/splat_test_util.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

void ExpectSame(const Splats& a, const Splats& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.sh_degree, b.sh_degree);
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.normal, b.normal);
  EXPECT_EQ(a.f_dc, b.f_dc);
  EXPECT_EQ(a.f_rest, b.f_rest);
  EXPECT_EQ(a.opacity, b.opacity);
  EXPECT_EQ(a.log_scale, b.log_scale);
  EXPECT_EQ(a.rotation, b.rotation);
  ASSERT_EQ(a.extras.size(), b.extras.size());
  for (size_t k = 0; k < a.extras.size(); ++k) {
    EXPECT_EQ(a.extras[k].name, b.extras[k].name);
    EXPECT_EQ(a.extras[k].type, b.extras[k].type);
    EXPECT_EQ(a.extras[k].values, b.extras[k].values);
  }
}

TEST(SplatPly, BinaryAndAsciiRoundTripsBitExactForEveryDegree) {
  for (int degree = 0; degree <= 3; ++degree) {
    const Splats s = RandomSplats(50, degree, 10 + degree, /*normals=*/degree % 2 == 0);
    ExpectSame(ParseSplatPly(SerializeSplatPly(s), "binary.ply"), s);
    ExpectSame(ParseSplatPly(SerializeSplatPly(s, true), "ascii.ply"), s);
    EXPECT_EQ(ParseSplatPly(SerializeSplatPly(s), "b.ply").f_rest.rows(), 3 * ((degree + 1) * (degree + 1) - 1));
  }
}

// The INRIA layout as gaussian-splatting's save_ply writes it (degree 0 here), read by name.
TEST(SplatPly, ReadsTheInriaLayoutByName) {
  const std::string ply =
      "ply\nformat ascii 1.0\ncomment written by hand\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float f_dc_0\n"
      "property float f_dc_1\nproperty float f_dc_2\nproperty float opacity\nproperty float scale_0\n"
      "property float scale_1\nproperty float scale_2\nproperty float rot_0\nproperty float rot_1\n"
      "property float rot_2\nproperty float rot_3\nend_header\n"
      "1 2 3 0 0 0 0.1 0.2 0.3 -1.5 -3 -4 -5 2 0 0 0\n"
      "-1 -2 -3 0 0 1 0 0 0 4 -2 -2 -2 0 0 0 0.5\n";
  const Splats s = ParseSplatPly(ply, "inria.ply");
  ASSERT_EQ(s.size(), 2);
  EXPECT_EQ(s.sh_degree, 0);
  EXPECT_TRUE(s.has_normals());
  EXPECT_EQ(s.position.col(0), Eigen::Vector3f(1, 2, 3));
  EXPECT_FLOAT_EQ(s.f_dc(2, 0), 0.3f);
  EXPECT_FLOAT_EQ(s.opacity(1), 4.f);
  EXPECT_EQ(s.log_scale.col(0), Eigen::Vector3f(-3, -4, -5));
  EXPECT_EQ(s.rotation.col(1), Eigen::Vector4f(0, 0, 0, 0.5f));
  EXPECT_TRUE(s.extras.empty());
}

TEST(SplatPly, IsSplatPlyTellsSplatsFromMeshesAndOtherFiles) {
  ScopedTempDir dir;
  WriteSplatPly(RandomSplats(3, 1, 1), dir.File("s.ply"));
  WriteFileAtomic(dir.File("m.ply"),
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                  "property float z\nend_header\n0 0 0\n");
  WriteFileAtomic(dir.File("t.json"), "{}");
  EXPECT_TRUE(IsSplatPly(dir.File("s.ply")));
  EXPECT_FALSE(IsSplatPly(dir.File("m.ply")));
  EXPECT_FALSE(IsSplatPly(dir.File("t.json")));
  EXPECT_FALSE(IsSplatPly(dir.File("missing.ply")));
}

// A valid one-splat ASCII file with one line of the header or body replaced.
std::string AsciiWith(const std::string& from, const std::string& to) {
  std::string s = SerializeSplatPly(RandomSplats(1, 0, 7, false), true);
  s.replace(s.find(from), from.size(), to);
  return s;
}

std::string PlyErrorOf(const std::string& bytes) {
  return InputErrorOf([&] { ParseSplatPly(bytes, "bad.ply"); });
}

TEST(SplatPly, RefusesBadHeadersNamingTheFileAndField) {
  EXPECT_EQ(PlyErrorOf(AsciiWith("property float opacity\n", "")),
            "bad.ply: property opacity: expected a float property of the vertex element (it is missing)");
  EXPECT_EQ(PlyErrorOf(AsciiWith("property float scale_1", "property double scale_1")),
            "bad.ply: property scale_1: expected type float (got double)");
  EXPECT_EQ(
      PlyErrorOf(AsciiWith("format ascii 1.0", "format binary_big_endian 1.0")).rfind("bad.ply: format: expected", 0),
      0u);
  EXPECT_EQ(PlyErrorOf(AsciiWith("property float x", "property list uchar float x")),
            "bad.ply: property x: expected a scalar property (the vertex element has no lists)");
  EXPECT_EQ(PlyErrorOf(AsciiWith("element vertex 1", "element face 1")),
            "bad.ply: element face: expected the vertex element first");
  EXPECT_EQ(PlyErrorOf(AsciiWith("ply\n", "plx\n")), "bad.ply: magic: expected a PLY file (first line \"ply\")");
  EXPECT_EQ(PlyErrorOf(AsciiWith("end_header\n", "")).substr(0, 25), "bad.ply: header: expected");
  // f_rest of no SH degree.
  EXPECT_EQ(PlyErrorOf(AsciiWith("property float opacity", "property float f_rest_0\nproperty float opacity")),
            "bad.ply: property f_rest_0: expected 0, 9, 24 or 45 f_rest properties (SH degree 0-3), got 1");
}

TEST(SplatPly, RefusesBadValuesNamingTheVertex) {
  Splats s = RandomSplats(3, 1, 8);
  s.opacity(1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(PlyErrorOf(SerializeSplatPly(s)),
            "bad.ply: vertex[1].opacity: expected a finite number (not NaN or infinite)");
  s = RandomSplats(3, 1, 8);
  s.rotation.col(2).setZero();
  EXPECT_EQ(PlyErrorOf(SerializeSplatPly(s)),
            "bad.ply: vertex[2].rot: expected a non-zero quaternion (rot_0..3 are all zero)");
  s = RandomSplats(3, 2, 8);
  s.f_rest(5, 0) = std::numeric_limits<float>::infinity();
  EXPECT_EQ(PlyErrorOf(SerializeSplatPly(s, true)),
            "bad.ply: vertex[0].f_rest: expected finite numbers (not NaN or infinite)");
  s = RandomSplats(3, 0, 8);
  s.log_scale(0, 0) = 100;
  EXPECT_EQ(PlyErrorOf(SerializeSplatPly(s)), "bad.ply: vertex[0].scale: expected log scales within [-40, 40]");
  EXPECT_EQ(PlyErrorOf(AsciiWith("\n-", "\nabc")).substr(0, 31), "bad.ply: vertex[0].x: expected ");
}

// A header claiming more vertices than the body can hold is refused from the header alone, before
// the arrays are sized (a 10^12-vertex claim would otherwise allocate terabytes).
TEST(SplatPly, RefusesAVertexCountTheFileCannotHoldBeforeAllocating) {
  const Splats s = RandomSplats(4, 3, 9);
  std::string binary = SerializeSplatPly(s);
  binary.replace(binary.find("element vertex 4"), 16, "element vertex 999999999999");
  const std::string e = PlyErrorOf(binary);
  EXPECT_NE(e.find("bad.ply: element vertex: expected at most 4 vertices"), std::string::npos) << e;
  EXPECT_NE(e.find("the header claims 999999999999"), std::string::npos) << e;
  std::string truncated = SerializeSplatPly(s);
  truncated.resize(truncated.size() - 1);
  EXPECT_NE(PlyErrorOf(truncated).find("expected at most 3 vertices"), std::string::npos);
  std::string ascii = SerializeSplatPly(s, true);
  ascii.replace(ascii.find("element vertex 4"), 16, "element vertex 100000000");
  EXPECT_NE(PlyErrorOf(ascii).find("bad.ply: element vertex: expected at most"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
