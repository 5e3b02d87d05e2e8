#include "nerfreg/render/sh3f.h"

#include <gtest/gtest.h>

#include "nerfreg/geometry/conventions.h"
#include "nerfreg/render/raycaster.h"
#include "nerfreg/render/renderer.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// A texture whose left half (u < 0.5) is red and right half green.
std::string RedGreenPng() {
  Image tex(16, 8, 3);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      tex.at(x, y, 0) = x < 8 ? 0.9f : 0.1f;
      tex.at(x, y, 1) = x < 8 ? 0.1f : 0.9f;
      tex.at(x, y, 2) = 0.1f;
    }
  return EncodeImage(tex, ".png", "tex.png", 95);
}

const char* kCatalog =
    "# a test catalog\n"
    "id=test\n"
    "id#1=Test#panel\n"
    "name#1=Panel \\u00e9\\\n"
    "  continued\n"
    "category#1=Test\n"
    "model#1=/test/panel/panel.obj\n"
    "width#1=200\n"
    "height#1=100\n"
    "depth#1=10\n"
    "id#2=Test#lost\n"
    "model#2=/test/lost.obj\n";

// Two quads side by side in z = 0: x in [-1, 0] textured (u from 0 to 1 across x), x in [0, 1]
// a flat blue material.
const char* kObj =
    "mtllib panel.mtl\n"
    "v -1 -0.5 0\nv 0 -0.5 0\nv 0 0.5 0\nv -1 0.5 0\nv 1 -0.5 0\nv 1 0.5 0\nv 9 9 9\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "usemtl textured\nf 1/1 2/2 3/3 4/4\n"
    "usemtl flat\nf 2 5 6 -5\n";

std::string Mtl(const std::string& texture) {
  return "newmtl textured\nKd 1 1 1\nmap_Kd -s 1 1 1 " + texture + "\nnewmtl flat\nKd 0.1 0.2 0.9\n";
}

std::string WriteArchive(const ScopedTempDir& dir, const std::vector<TestZipEntry>& entries) {
  const std::string path = dir.File("test.sh3f");
  WriteFileAtomic(path, MakeTestZip(entries));
  return path;
}

TEST(Sh3f, ReadsCatalogObjMtlAndTextureAndTheTextureReachesTheRender) {
  ScopedTempDir dir;
  WriteArchive(dir, {{"PluginFurnitureCatalog.properties", kCatalog},
                     {"test/panel/panel.obj", kObj},
                     {"test/panel/panel.mtl", Mtl("textures\\tex.png")},
                     {"test/panel/textures/tex.png", RedGreenPng(), false}});
  std::vector<std::string> warnings;
  const std::vector<Sh3fModel> models = ReadSh3fCatalogs(dir.path(), &warnings);
  ASSERT_EQ(models.size(), 1u);  // "lost" names an OBJ the archive lacks
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("Test#lost"), std::string::npos);
  EXPECT_EQ(models[0].id, "Test#panel");
  EXPECT_EQ(models[0].name,
            "Panel \xc3\xa9"
            "continued");
  EXPECT_EQ(models[0].model, "test/panel/panel.obj");
  EXPECT_EQ(models[0].size_cm, Eigen::Vector3f(200, 100, 10));

  ObjReadReport report;
  TriangleMesh mesh = LoadSh3fModel(models[0], ObjReadOptions(), &report);
  EXPECT_EQ(report.warning_count, 0) << (report.warnings.empty() ? "" : report.warnings[0]);
  EXPECT_EQ(report.textures, 1);
  ASSERT_TRUE(mesh.HasMaterials());
  EXPECT_EQ(mesh.vertices.size(), 6u);  // the unused vertex dropped
  EXPECT_EQ(mesh.triangles.size(), 4u);
  Eigen::Vector3f mn, mx;
  mesh.Bounds(&mn, &mx);
  EXPECT_NEAR(mx.x() - mn.x(), 200.f, 1e-3);  // scaled to the catalog's size
  EXPECT_NEAR(mx.y() - mn.y(), 100.f, 1e-3);

  NormalizeMesh(&mesh);
  RayCaster caster(mesh);
  const Camera cam = Camera::Pinhole(80, 80, 60, 60, 40, 40);
  RenderOptions ro;
  ro.supersample = 1;
  const RenderResult r = RenderView(caster, mesh, cam, LookAt({0, 0, 4}, {0, 0, 0}, Eigen::Vector3d::UnitY()), ro);
  // Count pixels by dominant channel and where they lie along the image's rows.
  int count[3] = {0, 0, 0};
  double column_sum[3] = {0, 0, 0};
  for (int y = 0; y < 80; ++y)
    for (int x = 0; x < 80; ++x) {
      if (r.rgba.at(x, y, 3) < 1) continue;
      const Eigen::Vector3f c(r.rgba.at(x, y, 0), r.rgba.at(x, y, 1), r.rgba.at(x, y, 2));
      int k;
      c.maxCoeff(&k);
      if (c[k] < 1.5f * (c.sum() - c[k]) / 2) continue;  // not clearly one colour
      ++count[k];
      column_sum[k] += x;
    }
  ASSERT_GT(count[0], 100);  // red: the texture's left half
  ASSERT_GT(count[1], 100);  // green: its right half
  ASSERT_GT(count[2], 200);  // blue: the flat material
  EXPECT_NEAR(count[0], count[1], 0.2 * count[0]);
  EXPECT_NEAR(count[0] + count[1], count[2], 0.2 * count[2]);
  // Red lies farther from blue than green does: u runs from red to green towards the blue quad.
  const double red = column_sum[0] / count[0], green = column_sum[1] / count[1], blue = column_sum[2] / count[2];
  EXPECT_GT(std::abs(red - blue), std::abs(green - blue) + 5);  // 23.4 and 14 pixels
}

TEST(Sh3f, AMissingTextureOrBrokenMtlIsAWarningAndAFlatColour) {
  ScopedTempDir dir;
  const std::string path = WriteArchive(
      dir, {{"PluginFurnitureCatalog.properties", kCatalog},
            {"test/panel/panel.obj", kObj},
            {"test/panel/panel.mtl", "Kd 1 1 1\n" + Mtl("C:/Documents and Settings/me/gone.png") + "Kd red\n"}});
  const ZipReader zip = ZipReader::Open(path);
  ObjReadReport report;
  const TriangleMesh mesh = LoadSh3fModel(zip, ReadSh3fCatalog(zip).at(0), ObjReadOptions(), &report);
  EXPECT_EQ(report.missing_textures, 1);
  EXPECT_EQ(report.warning_count, 3);
  std::string all;
  for (const auto& w : report.warnings) all += w + "\n";
  EXPECT_NE(all.find("Kd before any newmtl"), std::string::npos) << all;
  EXPECT_NE(all.find("texture C:/Documents and Settings/me/gone.png: no such file (flat colour)"), std::string::npos)
      << all;
  EXPECT_NE(all.find("panel.mtl: line 7: expected \"Kd r g b\""), std::string::npos) << all;
  ASSERT_TRUE(mesh.HasMaterials());
  for (const auto& m : mesh.materials) EXPECT_TRUE(m.texture.empty());
}

TEST(Sh3f, TraversalNamesAndOversizeEntriesAreNamedErrors) {
  {
    ScopedTempDir dir;
    WriteArchive(dir, {{"PluginFurnitureCatalog.properties", kCatalog}, {"test/../../evil.obj", kObj}});
    const std::string error = InputErrorOf([&] { ReadSh3fCatalogs(dir.path()); });
    EXPECT_NE(error.find("test.sh3f: entry \"test/../../evil.obj\": expected a path inside the archive"),
              std::string::npos)
        << error;
  }
  {
    // A bomb: an entry declaring 1 GiB uncompressed.
    ScopedTempDir dir;
    std::string zip = MakeTestZip({{"PluginFurnitureCatalog.properties", kCatalog}, {"test/panel/panel.obj", kObj}});
    size_t at = zip.find(std::string("PK\x01\x02", 4));
    at = zip.find(std::string("PK\x01\x02", 4), at + 4);
    for (int k = 0; k < 4; ++k) zip[at + 24 + k] = static_cast<char>(((1u << 30) >> (8 * k)) & 0xff);
    WriteFileAtomic(dir.File("bomb.sh3f"), zip);
    const std::string error = InputErrorOf([&] { ReadSh3fCatalogs(dir.path()); });
    EXPECT_NE(error.find("bomb.sh3f: entry \"test/panel/panel.obj\": expected at most 268435456 bytes uncompressed"),
              std::string::npos)
        << error;
  }
  ScopedTempDir empty;
  EXPECT_NE(InputErrorOf([&] { ReadSh3fCatalogs(empty.path()); }).find("a folder of .sh3f"), std::string::npos);
}

TEST(ObjReader, BrokenObjsAreNamedErrorsOrSkippedFaces) {
  const ObjFileSource none = [](const std::string&, std::string*) { return false; };
  EXPECT_NE(InputErrorOf([&] {
              ReadObjWithMaterials("\x89PNG garbage\n\0\1\2", "x.obj", none);
            }).find("x.obj: expected an OBJ"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] {
              ReadObjWithMaterials("v 0 0 0\nv 1 0 0\nf 1 2 3\n", "x.obj", none);
            }).find("x.obj: faces: expected at least one face"),
            std::string::npos);
  ObjReadReport report;
  const TriangleMesh m = ReadObjWithMaterials(
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv nan 0 0\nf 1 2 3 4\nf -4 -3\nf 1/9 2/9 3/9\nf 1 2 99\nl 1 2\n"
      "usemtl none\nf 1// 3//1 4//\n",
      "x.obj", none, ObjReadOptions(), &report);
  EXPECT_EQ(report.skipped_faces, 2);  // "f -4 -3" and "f 1 2 99"
  EXPECT_EQ(m.triangles.size(), 4u);   // the quad fanned, one with unknown vt, one more
  EXPECT_EQ(m.vertices.size(), 4u);
  EXPECT_TRUE(m.triangle_uvs.empty());
  ASSERT_EQ(report.warning_count, 4) << report.warnings[0];  // the nan vertex, 2 faces, usemtl none
  EXPECT_NE(report.warnings[0].find("x.obj: line 5: expected \"v x y z\""), std::string::npos);
  EXPECT_EQ(m.materials[m.triangle_materials.back()].name, "none");
}

TEST(Sh3f, JavaPropertiesEscapesAndContinuations) {
  const auto p = ParseJavaProperties("a=1\n# c\n! c\nb : two \\\n   three\r\nc\\=d=\\u0041\\tx\nlatin=\xe9\n");
  ASSERT_EQ(p.size(), 4u);
  EXPECT_EQ(p[1], std::make_pair(std::string("b"), std::string("two three")));
  EXPECT_EQ(p[2], std::make_pair(std::string("c=d"), std::string("A\tx")));
  EXPECT_EQ(p[3].second, "\xc3\xa9");
}

}  // namespace
}  // namespace nerfreg
