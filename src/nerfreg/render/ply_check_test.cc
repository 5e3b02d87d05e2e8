// CheckPlyForOpen3d reads a PLY as rply does, so the faces Open3D triangulates are the faces it
// checks. Each case here is a way the earlier line-based check and rply disagreed about where a
// value is, and Open3D then read an empty or out-of-range face (SEGV in its ear clipping).
#include "nerfreg/render/ply_check.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "nerfreg/render/mesh.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

const char kAsciiVertices[] =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n";
const char kQuad[] = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";

class PlyCheck : public ::testing::Test {
 protected:
  // The error CheckPlyForOpen3d throws on `contents` ("" when it accepts the file).
  std::string ErrorOf(const std::string& contents) {
    WriteFileAtomic(path_, contents);
    try {
      CheckPlyForOpen3d(path_);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  ScopedTempDir dir_;
  const std::string path_ = dir_.File("m.ply");
};

TEST_F(PlyCheck, ValidAsciiAndBinaryFilesPassAndLoad) {
  const std::string ascii = std::string(kAsciiVertices) +
                            "element face 1\nproperty list uchar int vertex_indices\nend_header\n" + kQuad +
                            "4 0 1 2 3\n";
  EXPECT_EQ(ErrorOf(ascii), "");
  EXPECT_EQ(LoadMesh(path_).triangles.size(), 2u);
  // Big-endian binary, "\r\n" line breaks (rply then skips one byte more after end_header).
  std::string big =
      "ply\r\nformat binary_big_endian 1.0\r\nelement vertex 3\r\nproperty float x\r\n"
      "property float y\r\nproperty float z\r\nelement face 1\r\n"
      "property list uchar int vertex_indices\r\nend_header\r\n";
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (float f : xyz) {
    const char* b = reinterpret_cast<const char*>(&f);
    big += std::string{b[3], b[2], b[1], b[0]};
  }
  big += std::string("\x03\0\0\0\0\0\0\0\x01\0\0\0\x02", 13);
  EXPECT_EQ(ErrorOf(big), "");
  EXPECT_EQ(LoadMesh(path_).triangles.size(), 1u);
}

TEST_F(PlyCheck, HeaderKeywordsAreReadAsWordsLikeRply) {
  // A property on its element's line (fuzzer find): rply reads the face list, so must we.
  const std::string e = ErrorOf(std::string(kAsciiVertices) +
                                "element face 1 property list uchar int vertex_indices\nend_header\n" + kQuad + "0\n");
  EXPECT_EQ(e.rfind(path_ + ": face 0:", 0), 0u) << e;
  EXPECT_NE(e.find("at least 3 vertices (got 0)"), std::string::npos) << e;
  // A bare "comment" takes the next line as its text in rply: the first face element is not one.
  EXPECT_NE(ErrorOf(std::string(kAsciiVertices) +
                    "comment\nelement face 1\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" +
                    kQuad + "3 0 1 9\n")
                .find("face 0"),
            std::string::npos);
  // Control bytes and headers rply would read past its first buffer are refused.
  EXPECT_NE(ErrorOf("ply\nformat ascii 1.0\nelement\vvertex 3\nend_header\n").find(": header: expected printable"),
            std::string::npos);
  std::string comments;
  for (int k = 0; k < 10; ++k) comments += "comment " + std::string(900, 'c') + "\n";
  EXPECT_NE(
      ErrorOf("ply\nformat ascii 1.0\n" + comments + "end_header\n").find(": header: expected a PLY header of at most"),
      std::string::npos);
  EXPECT_NE(ErrorOf("ply\nformat ascii 1.0\ncomment " + std::string(1100, 'c') + "\nend_header\n")
                .find(": comment: expected a line of at most 1023 bytes"),
            std::string::npos);
  // "3abc" is a count to rply's sscanf; refused here.
  EXPECT_NE(ErrorOf("ply\nformat ascii 1.0\nelement vertex 3abc\nend_header\n")
                .find("element vertex: expected a decimal count"),
            std::string::npos);
}

TEST_F(PlyCheck, AsciiValuesAreSplitLikeRply) {
  const std::string header =
      std::string(kAsciiVertices) + "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  // A NUL ends a word in rply (fuzzer find): "0\0" is a face of 0 vertices.
  std::string e = ErrorOf(header + kQuad + std::string("0\0 1 2\n", 7));
  EXPECT_NE(e.find("face 0: expected a polygon of at least 3 vertices"), std::string::npos) << e;
  // An index rply reads as out of range is one here too.
  EXPECT_NE(ErrorOf(header + kQuad + "3 0 1 4\n").find("vertex indices below the vertex count 4"), std::string::npos);
  // The last value must not end the file (rply reads past it into its buffer's previous fill).
  EXPECT_NE(ErrorOf(header + kQuad + "3 0 1 2").find("the file ends inside it"), std::string::npos);
}

TEST_F(PlyCheck, TheFaceListOpen3dReadsIsTheOneChecked) {
  // Two vertex_indices lists: rply calls Open3D back on the first.
  std::string e = ErrorOf(std::string(kAsciiVertices) +
                          "element face 1\nproperty list uchar int vertex_indices\n"
                          "property list uchar int vertex_indices\nend_header\n" +
                          kQuad + "3 0 1 7 3 0 1 2\n");
  EXPECT_NE(e.find("face 0: expected vertex indices below"), std::string::npos) << e;
  // A list of negative length before the faces is read as empty by rply; the check goes on.
  e = ErrorOf(
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "property list char int extra\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0 -1\n1 0 0 0\n1 1 0 0\n0 1 0 0\n2 0 1\n");
  EXPECT_NE(e.find("face 0: expected a polygon of at least 3 vertices (got 2)"), std::string::npos) << e;
  // A float list count (cast to long by rply) and a scalar face "list" are refused.
  EXPECT_NE(
      ErrorOf(std::string(kAsciiVertices) + "element face 1\nproperty list float int vertex_indices\nend_header\n")
          .find("integer COUNT_TYPE"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(std::string(kAsciiVertices) + "element face 1\nproperty int vertex_indices\nend_header\n" + kQuad + "0\n")
          .find("property vertex_indices: expected a list"),
      std::string::npos);
}

}  // namespace
}  // namespace nerfreg
