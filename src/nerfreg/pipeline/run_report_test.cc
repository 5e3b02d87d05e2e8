#include "nerfreg/pipeline/run_report.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

std::string AsciiPly(int n) {
  std::string s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(n) +
                  "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
                  "property uchar blue\nend_header\n";
  for (int i = 0; i < n; ++i) s += std::to_string(i) + " " + std::to_string(2 * i) + " 0.5 10 20 30\n";
  return s;
}

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST(RunReport, PlyPointsAreStridedToTheCap) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("a.ply"), AsciiPly(10));
  const Eigen::Matrix3Xd all = ReadPlyPoints(dir.File("a.ply"), 100);
  ASSERT_EQ(all.cols(), 10);
  EXPECT_EQ(all.col(7), Eigen::Vector3d(7, 14, 0.5));
  const Eigen::Matrix3Xd few = ReadPlyPoints(dir.File("a.ply"), 4);  // every 3rd: 0 3 6 9
  ASSERT_EQ(few.cols(), 4);
  EXPECT_EQ(few.col(3), Eigen::Vector3d(9, 18, 0.5));

  WriteFileAtomic(dir.File("bin.ply"),
                  "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n");
  EXPECT_NE(InputErrorOf([&] { ReadPlyPoints(dir.File("bin.ply"), 10); }).find("format: expected ascii"),
            std::string::npos);
  std::string two_of_three = AsciiPly(2);
  two_of_three.replace(two_of_three.find("vertex 2"), 8, "vertex 3");
  WriteFileAtomic(dir.File("short.ply"), two_of_three);
  EXPECT_NE(InputErrorOf([&] { ReadPlyPoints(dir.File("short.ply"), 10); }).find("short.ply: vertex 2"),
            std::string::npos);
}

TEST(RunReport, FrustumApexIsTheCameraCentreMappedByTheSimilarity) {
  Dataset ds;
  Frame f;
  f.name = "a.png";
  f.camera = Camera::Pinhole(40, 20, 20, 20, 20, 10);
  f.cam_from_world = Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, -3));  // centre (0, 0, 3)
  ds.frames.push_back(f);
  const Sim3d world_from_ds(2.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0));
  const Eigen::Matrix3Xd seg = CameraFrustumSegments(ds, world_from_ds, 0.5);
  ASSERT_EQ(seg.cols(), 16);
  EXPECT_TRUE(seg.col(0).isApprox(Eigen::Vector3d(1, 0, 6)));
  // The top-left corner: pixel (0, 0) at depth 0.5 is (-0.5, -0.25, 0.5) in the camera.
  EXPECT_TRUE(seg.col(1).isApprox(Eigen::Vector3d(1 + 2 * -0.5, 2 * -0.25, 2 * 3.5)));
}

TEST(RunReport, HeatMapIsBlackWhereEqualAndWhereTheErrorSaturates) {
  Image a(2, 1, 3, 0.5f), b(2, 1, 3, 0.5f);
  for (int c = 0; c < 3; ++c) b.at(1, 0, c) = 1.0f;
  const Image h = ErrorHeatMap(a, b);
  EXPECT_EQ(h.at(0, 0, 0), 0.f);
  EXPECT_EQ(h.at(1, 0, 0), 1.f);
  EXPECT_EQ(h.at(1, 0, 2), 1.f);
}

// A run as the demo leaves it: two blocks' datasets, a registration with its errors and
// overlays, the blocks' points, renders of block 0 and a training log.
std::string WriteRun(const ScopedTempDir& dir) {
  const std::string run = dir.File("run");
  for (int b = 0; b < 2; ++b) {
    Dataset ds;
    for (int k = 0; k < 3; ++k) {
      Frame f;
      f.file_path = "images/r_00" + std::to_string(k) + ".png";
      f.name = "r_00" + std::to_string(k) + ".png";
      f.camera = Camera::Pinhole(8, 8, 8, 8, 4, 4);
      f.cam_from_world = Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(k, 0, 4));
      ds.frames.push_back(f);
      WriteImage(run + "/data/block_" + std::to_string(b) + "/" + f.file_path, Image(8, 8, 3, 0.2f));
    }
    WriteTransformsJson(ds, run + "/data/block_" + std::to_string(b) + "/transforms.json");
    WriteFileAtomic(run + "/block_" + std::to_string(b) + ".ply", AsciiPly(50));
    // Renders 0.2 off the ground truth everywhere (51 of 255 levels): PSNR 13.98 dB.
    if (b == 0)
      for (int k = 0; k < 3; ++k)
        WriteImage(run + "/renders_block_0/r_00" + std::to_string(k) + ".png", Image(8, 8, 3, 0.4f));
  }
  Json t = {{"target_from_source", MatrixToJson(Eigen::Matrix4d::Identity())},
            {"method", "ransac+icp"},
            {"seconds", 1.5},
            {"confidence", 0.9},
            {"source", run + "/block_0.ckpt"},
            {"target", run + "/block_1.ckpt"}};
  WriteJsonFile(run + "/target_from_source_auto.json", t);
  WriteJsonFile(run + "/errors_auto.json",
                Json{{"rotation_error_deg", 1.25}, {"translation_error", 0.01}, {"translation_error_fraction", 0.004}});
  WriteImage(run + "/target_from_source_auto_before.png", Image(6, 6, 3, 0.2f));
  WriteImage(run + "/target_from_source_auto_after.png", Image(6, 6, 3, 0.3f));
  WriteFileAtomic(run + "/block_0.ckpt.log.jsonl",
                  "{\"step\": 50, \"loss\": 0.1}\n{\"step\": 100, \"loss\": 0.01, \"test_psnr\": 21, \"seconds\": 12}\n"
                  "{\"step\": 150, \"loss\": 0.001, \"test_psnr\": 23, \"seconds\": 19}\n");
  return run;
}

TEST(RunReport, PageShowsEveryPartOfTheRun) {
  ScopedTempDir dir;
  const std::string run = WriteRun(dir);
  ReportOptions options;
  options.three_js = dir.File("three.min.js");
  WriteFileAtomic(options.three_js, "var THREE = {}; /*fake three.js</script>*/");
  WriteRunReport(run, dir.File("report.html"), options);
  const std::string html = ReadFileToString(dir.File("report.html"));
  // three.js inlined once, its "</script" defused; one 3D view for the registered blocks (no
  // other posed set: both datasets are drawn in it).
  EXPECT_EQ(Count(html, "/*fake three.js<\\/script>*/"), 1u);
  EXPECT_EQ(Count(html, "<canvas"), 1u);
  EXPECT_NE(html.find("apply T"), std::string::npos);
  EXPECT_NE(html.find("cameras of block_0"), std::string::npos);
  // The errors and the time in the summary card, the overlays embedded.
  EXPECT_NE(html.find("1.25&deg;"), std::string::npos);
  EXPECT_NE(html.find("1.5 s"), std::string::npos);
  EXPECT_NE(html.find("alt=\"before\" src=\"data:image/png;base64,"), std::string::npos);
  // Renders next to ground truth and heat-map, each view at 13.98 dB, the mean too.
  EXPECT_EQ(Count(html, "alt=\"error\" src=\"data:image/jpeg;base64,"), 3u);
  EXPECT_EQ(Count(html, "<td>13.98</td>"), 3u);
  EXPECT_NE(html.find("13.98 dB</b> over 3 views"), std::string::npos);
  // The loss on a log axis, the PSNR on a linear one, both labelled; the training time.
  EXPECT_NE(html.find(">loss (log scale)</text>"), std::string::npos);
  EXPECT_NE(html.find(">test_psnr</text>"), std::string::npos);
  EXPECT_NE(html.find("19 s"), std::string::npos);
  // Nothing fetched when viewed.
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("src=\"file"), std::string::npos);
}

TEST(RunReport, MissingThreeJsIsANamedErrorOnlyWhenA3dViewIsNeeded) {
  ScopedTempDir dir;
  const std::string run = WriteRun(dir);
  ReportOptions options;
  options.three_js = dir.File("absent/three.min.js");
  const std::string err = InputErrorOf([&] { WriteRunReport(run, dir.File("r.html"), options); });
  EXPECT_NE(err.find("absent/three.min.js: three.js: expected"), std::string::npos) << err;
  EXPECT_NE(err.find("libjs-three"), std::string::npos);
  EXPECT_FALSE(FileExists(dir.File("r.html")));
  // Without point clouds or datasets there is no 3D view and no need for three.js.
  const std::string plain = dir.File("plain");
  WriteFileAtomic(plain + "/metrics.json", R"({"psnr": 27.5, "note": "<b>"})");
  WriteRunReport(plain, dir.File("plain.html"), options);
  const std::string html = ReadFileToString(dir.File("plain.html"));
  EXPECT_NE(html.find("27.5"), std::string::npos);
  EXPECT_NE(html.find("&lt;b&gt;"), std::string::npos);
  EXPECT_EQ(html.find("<canvas"), std::string::npos);
  EXPECT_THROW(WriteRunReport(dir.File("missing"), dir.File("r2.html"), ReportOptions{}), InputError);
}

}  // namespace
}  // namespace nerfreg
