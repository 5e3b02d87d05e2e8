#include "nerfreg/data/colmap.h"

#include <gtest/gtest.h>

#include <cstdlib>

#include "nerfreg/data/convert.h"
#include "nerfreg/data/test_data.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

ColmapModel ModelWithPoints(const std::string& root) {
  ColmapModel m = ColmapFromDataset(MakeRingDataset(root, 5, /*distortion=*/true));
  ColmapPoint3D p;
  p.point3d_id = 7;
  p.xyz = Eigen::Vector3d(0.1, -0.2, 0.3);
  p.rgb[0] = 200;
  p.rgb[1] = 10;
  p.rgb[2] = 30;
  p.error = 0.5;
  p.track = {{1, 0}, {2, 0}};
  m.points3d[7] = p;
  m.images[1].points2d = {{3.5, 4.25, 7}, {1.0, 2.0, -1}};
  m.images[2].points2d = {{5.5, 6.25, 7}};
  return m;
}

void ExpectSameModel(const ColmapModel& a, const ColmapModel& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  ASSERT_EQ(a.images.size(), b.images.size());
  ASSERT_EQ(a.points3d.size(), b.points3d.size());
  for (const auto& [id, cam] : a.cameras) {
    EXPECT_EQ(cam.model, b.cameras.at(id).model);
    ASSERT_EQ(cam.params.size(), b.cameras.at(id).params.size());
    for (size_t k = 0; k < cam.params.size(); ++k) EXPECT_NEAR(cam.params[k], b.cameras.at(id).params[k], 1e-9);
  }
  for (const auto& [id, im] : a.images) {
    const auto& o = b.images.at(id);
    EXPECT_EQ(im.name, o.name);
    EXPECT_LT((im.cam_from_world.ToMatrix() - o.cam_from_world.ToMatrix()).cwiseAbs().maxCoeff(), 1e-9);
    ASSERT_EQ(im.points2d.size(), o.points2d.size());
    for (size_t k = 0; k < im.points2d.size(); ++k) EXPECT_EQ(im.points2d[k].point3d_id, o.points2d[k].point3d_id);
  }
  for (const auto& [id, p] : a.points3d) {
    EXPECT_LT((p.xyz - b.points3d.at(id).xyz).norm(), 1e-9);
    EXPECT_EQ(p.track.size(), b.points3d.at(id).track.size());
    EXPECT_EQ(p.rgb[0], b.points3d.at(id).rgb[0]);
  }
}

TEST(Colmap, TextAndBinaryRoundTrips) {
  ScopedTempDir dir;
  const ColmapModel m = ModelWithPoints(dir.path());
  WriteColmapText(m, dir.File("txt"));
  WriteColmapBinary(m, dir.File("bin"));
  ExpectSameModel(m, ReadColmapModel(dir.File("txt")));
  ExpectSameModel(m, ReadColmapModel(dir.File("bin")));
}

TEST(Colmap, ModelsLoadInTheRealColmapAndBack) {
  if (std::system("command -v colmap >/dev/null 2>&1") != 0) GTEST_SKIP() << "colmap not installed";
  ScopedTempDir dir;
  const ColmapModel m = ModelWithPoints(dir.path());
  WriteColmapText(m, dir.File("ours_txt"));
  WriteColmapBinary(m, dir.File("ours_bin"));
  CreateDirectories(dir.File("colmap_bin"));
  CreateDirectories(dir.File("colmap_txt"));
  // COLMAP reads our text model and writes binary; reads our binary model and writes text.
  const std::string env = "QT_QPA_PLATFORM=offscreen ";
  ASSERT_EQ(std::system((env + "colmap model_converter --input_path " + dir.File("ours_txt") + " --output_path " +
                         dir.File("colmap_bin") + " --output_type BIN >/dev/null 2>&1")
                            .c_str()),
            0);
  ASSERT_EQ(std::system((env + "colmap model_converter --input_path " + dir.File("ours_bin") + " --output_path " +
                         dir.File("colmap_txt") + " --output_type TXT >/dev/null 2>&1")
                            .c_str()),
            0);
  ExpectSameModel(m, ReadColmapBinary(dir.File("colmap_bin")));
  ExpectSameModel(m, ReadColmapText(dir.File("colmap_txt")));
}

TEST(Colmap, WorldPointProjectsToTheSamePixelThroughEveryFormat) {
  // transforms.json -> COLMAP (bin) -> LLFF -> transforms.json: the same world point lands on the
  // same pixel in every camera at every step.
  ScopedTempDir dir;
  const Dataset d = MakeRingDataset(dir.path(), 6, false, /*centred=*/true);
  WriteTransformsJson(d, dir.File("a/transforms.json"));
  ConvertOptions to_colmap{"colmap", true, false};
  WriteCameras(ReadCameras(dir.File("a/transforms.json")), dir.File("b/sparse/0"), to_colmap);
  ConvertOptions to_llff{"llff", false, false};
  WriteCameras(ReadCameras(dir.File("b/sparse/0")), dir.File("c"), to_llff);
  // LLFF needs its images beside poses_bounds.npy.
  for (const auto& f : d.frames) WriteImage(dir.File("c/images/" + f.name), Image(24, 16, 3));
  ConvertOptions to_nerf{"nerf", false, false};
  WriteCameras(ReadCameras(dir.File("c")), dir.File("d/transforms.json"), to_nerf);
  const Dataset back = ReadCameras(dir.File("d/transforms.json"));
  const Eigen::Vector3d x(0.3, -0.2, 0.5);
  for (const auto& f : d.frames) {
    const Frame* g = nullptr;
    for (const auto& h : back.frames)
      if (h.name == f.name) g = &h;
    ASSERT_NE(g, nullptr);
    const Eigen::Vector2d a = f.camera.ImgFromCam(f.cam_from_world * x);
    const Eigen::Vector2d b = g->camera.ImgFromCam(g->cam_from_world * x);
    EXPECT_LT((a - b).norm(), 1e-8) << f.name;
  }
}

TEST(Colmap, TruncatedAndHostileBinariesAreNamedErrors) {
  ScopedTempDir dir;
  const ColmapModel m = ModelWithPoints(dir.path());
  WriteColmapBinary(m, dir.File("bin"));
  const std::string images = ReadFileToString(dir.File("bin/images.bin"));
  WriteFileAtomic(dir.File("bin/images.bin"), images.substr(0, images.size() / 2));
  try {
    ReadColmapBinary(dir.File("bin"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("images.bin"), std::string::npos) << e.what();
  }
  // A count of 10^12 cameras in a 20-byte file: refused before allocating.
  std::string huge(8, '\0');
  const std::uint64_t n = 1000000000000ull;
  std::memcpy(huge.data(), &n, 8);
  WriteFileAtomic(dir.File("bin/cameras.bin"), huge + std::string(12, '\0'));
  try {
    ReadColmapBinary(dir.File("bin"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras.bin: num_cameras"), std::string::npos) << e.what();
  }
}

TEST(Colmap, MalformedTextNamesTheLine) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("m/cameras.txt"), "# c\n1 PINHOLE 640 480 500 500 320\n");
  WriteFileAtomic(dir.File("m/images.txt"), "");
  try {
    ReadColmapText(dir.File("m"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras.txt: line 2 PARAMS"), std::string::npos) << e.what();
  }
  WriteFileAtomic(dir.File("m/cameras.txt"), "1 FISHEYE_X 640 480 1 2 3\n");
  EXPECT_THROW(ReadColmapText(dir.File("m")), InputError);
  WriteFileAtomic(dir.File("m/cameras.txt"), "1 PINHOLE 640 480 500 500 320 240\n");
  WriteFileAtomic(dir.File("m/images.txt"), "1 1 0 0 0 0 0 0 2 a.png\n\n");
  EXPECT_THROW(ReadColmapText(dir.File("m")), InputError);  // camera 2 unknown
}

}  // namespace
}  // namespace nerfreg
