// LoadMesh on tiny files of every format we guard, and the header checks found by fuzzing
// (fuzz/mesh_fuzz.cc): counts that the file cannot hold are an InputError naming the file and the
// count, not a multi-GB allocation inside Open3D.
#include "nerfreg/render/mesh.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

std::string BinaryStl(std::uint32_t count, int triangles) {
  std::string s(80, ' ');
  s.append(reinterpret_cast<const char*>(&count), 4);
  const float tri[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (int k = 0; k < triangles; ++k) {
    s.append(reinterpret_cast<const char*>(tri), sizeof(tri));
    s.append(2, '\0');
  }
  return s;
}

TEST(Mesh, TinyFilesOfEveryGuardedFormatLoad) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("t.off"), "OFF\n# a comment\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n");
  WriteFileAtomic(
      dir.File("t.ply"),
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n");
  WriteFileAtomic(dir.File("t.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n");
  WriteFileAtomic(dir.File("t.stl"), BinaryStl(1, 1));
  const TriangleMesh off = LoadMesh(dir.File("t.off"));
  EXPECT_EQ(off.vertices.size(), 4u);
  EXPECT_EQ(off.triangles.size(), 2u);
  const TriangleMesh ply = LoadMesh(dir.File("t.ply"));
  ASSERT_TRUE(ply.HasColors());
  EXPECT_FLOAT_EQ(ply.vertex_colors[1].y(), 1.f);
  EXPECT_EQ(LoadMesh(dir.File("t.obj")).triangles.size(), 2u);
  EXPECT_EQ(LoadMesh(dir.File("t.stl")).triangles.size(), 1u);
}

TEST(Mesh, HeaderCountsTheFileCannotHoldAreInputErrorsNamingFileAndCount) {
  ScopedTempDir dir;
  const std::string off = dir.File("huge.off"), ply = dir.File("huge.ply"), stl = dir.File("huge.stl");
  WriteFileAtomic(off, "OFF\n2000000000 1 0\n0 0 0\n3 0 0 0\n");
  WriteFileAtomic(ply,
                  "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                  "property float y\nproperty float z\nend_header\n");
  WriteFileAtomic(stl, BinaryStl(0xFFFFFFFFu, 1));
  std::string e = InputErrorOf([&] { LoadMesh(off); });
  EXPECT_NE(e.find(off), std::string::npos) << e;
  EXPECT_NE(e.find("vertex count"), std::string::npos) << e;
  e = InputErrorOf([&] { LoadMesh(ply); });
  EXPECT_NE(e.find(ply), std::string::npos) << e;
  EXPECT_NE(e.find("element vertex"), std::string::npos) << e;
  e = InputErrorOf([&] { LoadMesh(stl); });
  EXPECT_NE(e.find(stl), std::string::npos) << e;
  EXPECT_NE(e.find("triangle count"), std::string::npos) << e;
  // Truncated STL (count says 2, one is there) and OFF faces count.
  WriteFileAtomic(stl, BinaryStl(2, 1));
  EXPECT_NE(InputErrorOf([&] { LoadMesh(stl); }).find("triangle count"), std::string::npos);
  WriteFileAtomic(off, "OFF\n3 900000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_NE(InputErrorOf([&] { LoadMesh(off); }).find("face count"), std::string::npos);
}

// Found by fuzz/mesh_fuzz.cc: Open3D's OFF reader passed a face of 0 vertices (the line "0 0 1",
// read as a count of 0) to its ear clipping, which read out of bounds and crashed; an index beyond
// the vertex count did the same. The faces are checked before Open3D sees the file.
TEST(Mesh, OffFacesWithFewerThanThreeVerticesOrIndicesOutOfRangeAreInputErrors) {
  ScopedTempDir dir;
  const std::string path = dir.File("bad.off");
  // The fuzzer's input: a vertex line with an extra value shifts the lines, so "0 0 1" is a face.
  WriteFileAtomic(path, "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0 0\n0 1 0\n0 0 1\n3\n3 0 1 3\n");
  std::string e = InputErrorOf([&] { LoadMesh(path); });
  EXPECT_EQ(e.rfind(path + ": face 0:", 0), 0u) << e;
  EXPECT_NE(e.find("at least 3 vertices (got 0)"), std::string::npos) << e;
  WriteFileAtomic(path, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2 7\n");
  e = InputErrorOf([&] { LoadMesh(path); });
  EXPECT_EQ(e.rfind(path + ": face 0:", 0), 0u) << e;
  EXPECT_NE(e.find("(got 7)"), std::string::npos) << e;
  WriteFileAtomic(path, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
  EXPECT_NE(InputErrorOf([&] { LoadMesh(path); }).find("(got -1)"), std::string::npos);
  // The second input: a NUL-padded count line leaves too few lines, so a face line is missing.
  static const char kNulPadded[] = "OFF\n4 2 0\0\0\0003 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n";
  WriteFileAtomic(path, std::string(kNulPadded, sizeof(kNulPadded) - 1));
  e = InputErrorOf([&] { LoadMesh(path); });
  EXPECT_EQ(e.rfind(path + ": face 0:", 0), 0u) << e;
  EXPECT_NE(e.find("missing or unreadable"), std::string::npos) << e;
  // A quad with indices in range still loads (ear clipping makes two triangles).
  WriteFileAtomic(path, "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  EXPECT_EQ(LoadMesh(path).triangles.size(), 2u);
}

// Found by fuzz/mesh_fuzz.cc: Open3D's PLY reader crashed the same way on a binary face list of
// length 0 (the fuzzer shifted the body so the count byte read 0), and would on indices out of range.
TEST(Mesh, ObjFacesOfFewerThanThreeCornersLinesOrBadIndicesAreInputErrors) {
  ScopedTempDir dir;
  const std::string vertices = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
  const auto error_of = [&](const std::string& name, const std::string& faces) {
    WriteFileAtomic(dir.File(name), vertices + faces);
    return InputErrorOf([&] { LoadMesh(dir.File(name)); });
  };
  // The input the fuzzer found (Open3D read it out of bounds: SEGV), then its relatives.
  EXPECT_NE(error_of("a.obj", "f 1/1/3/1 4/4/1\n").find("a.obj"), std::string::npos);
  EXPECT_NE(error_of("b.obj", "f 1 2\n").find("at least 3 corners"), std::string::npos);
  EXPECT_NE(error_of("c.obj", "l 1 2 3\n").find("not surfaces"), std::string::npos);
  EXPECT_NE(error_of("d.obj", "f 1 2 9\n").find("4 vertices"), std::string::npos);
  EXPECT_NE(error_of("e.obj", "f 1 0 2\n"), "");
  EXPECT_NE(error_of("f.obj", "f 1/2 2/1 3/1\n"), "");  // one texture coordinate only
  EXPECT_NE(error_of("g.obj", "f 1 2 x\n"), "");
  EXPECT_NE(error_of("h.obj", "f1/1 -2/1/1 -1/1/1\nf 1 2 3\n"), "");  // Assimp reads "f1/1 ..." as a face
  EXPECT_NE(error_of("i.obj", "f 1 2 3 # a comment Assimp reads as corners\n"), "");
  // Assimp 5.2.5 reads past its line buffer on these (fuzzer find, heap-dependent SEGV in Open3D):
  // "v/vt/vn" before any "vt" line once a "vn" came, and a 4th index.
  WriteFileAtomic(dir.File("j.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf -3/1/1 -2/1/1 -1/1/1\nvt 0 0\n");
  EXPECT_NE(InputErrorOf([&] { LoadMesh(dir.File("j.obj")); }).find("after the first \"vt\" line"), std::string::npos);
  // Lines end at \r, \f and NUL for Assimp too: "f 1 2\r3" is a face of two corners.
  EXPECT_NE(error_of("k.obj", "f 1 2\r3 4\n").find("at least 3 corners"), std::string::npos);
  EXPECT_NE(error_of("l.obj", std::string("f 1 2\0 3\n", 10)).find("at least 3 corners"), std::string::npos);
  // Indices Assimp's atoi would step over differently ("01" is read as 1, then 1 again).
  EXPECT_NE(error_of("m.obj", "f 1 2 03\n"), "");
  EXPECT_NE(error_of("n.obj", "f 1 2 +3\n"), "");
  // Vertices Assimp does not keep (2 numbers, ".5" is no number to it) do not count; relative
  // indices count back from where they stand (Assimp threw on these and leaked its mesh).
  EXPECT_NE(error_of("p.obj", "v 0 1\nv .5 1 2\nf 1 2 5\n").find("4 vertices"), std::string::npos);
  WriteFileAtomic(dir.File("r.obj"), "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n");
  EXPECT_NE(InputErrorOf([&] { LoadMesh(dir.File("r.obj")); }).find("2 so far"), std::string::npos);
  EXPECT_NE(error_of("s.obj", "v 1 2 3 0\nf 1 2 3\n").find("w != 0"), std::string::npos);
  EXPECT_NE(error_of("t.obj", "# a comment \\\nf 1 2 3\n").find("line continuation"), std::string::npos);
  // A byte-order mark does not hide a face from the check.
  WriteFileAtomic(dir.File("o.obj"),
                  "\xEF\xBB\xBF"
                  "f 1 2\n" +
                      vertices);
  EXPECT_NE(InputErrorOf([&] { LoadMesh(dir.File("o.obj")); }).find("at least 3 corners"), std::string::npos);
  // Valid corner forms and negative (relative) indices load.
  EXPECT_EQ(error_of("ok.obj", "f 1/1 2/1 3/1\nf 1//1 3//1 4//1\nf -4/1/1 -3/1/1 -2/1/1\n"), "");
  EXPECT_EQ(LoadMesh(dir.File("ok.obj")).triangles.size(), 3u);
}

TEST(Mesh, PlyFacesWithFewerThanThreeVerticesOrIndicesOutOfRangeAreInputErrors) {
  ScopedTempDir dir;
  const std::string path = dir.File("bad.ply");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::string vertices(reinterpret_cast<const char*>(xyz), sizeof(xyz));
  auto face = [](unsigned char n, std::vector<std::int32_t> idx) {
    return std::string(1, char(n)) + std::string(reinterpret_cast<const char*>(idx.data()), 4 * idx.size());
  };
  WriteFileAtomic(path, header + vertices + face(3, {0, 1, 2}));
  EXPECT_EQ(LoadMesh(path).triangles.size(), 1u);  // the valid binary file loads
  WriteFileAtomic(path, header + vertices + face(0, {}));
  std::string e = InputErrorOf([&] { LoadMesh(path); });
  EXPECT_EQ(e.rfind(path + ": face 0:", 0), 0u) << e;
  EXPECT_NE(e.find("at least 3 vertices"), std::string::npos) << e;
  WriteFileAtomic(path, header + vertices + face(3, {0, 1, 3}));
  e = InputErrorOf([&] { LoadMesh(path); });
  EXPECT_NE(e.find("vertex indices below the vertex count 3"), std::string::npos) << e;
  // ASCII, a quad with a negative index.
  WriteFileAtomic(path,
                  "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                  "element face 1\nproperty list uchar int vertex_index\nend_header\n"
                  "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 -1\n");
  EXPECT_NE(InputErrorOf([&] { LoadMesh(path); }).find("face 0"), std::string::npos);
  // The fuzzer's next input: a tab after end_header moved where rply starts the body.
  WriteFileAtomic(path, header.substr(0, header.size() - 1) + "\t" + vertices + face(3, {0, 1, 2}));
  EXPECT_NE(InputErrorOf([&] { LoadMesh(path); }).find(path + ": end_header:"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
