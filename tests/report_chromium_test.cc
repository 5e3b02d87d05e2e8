// The HTML report opens in headless Chromium with no console errors, shows its images and draws
// its 3D view (the canvas is not blank, in the WebGL read-back and in a real screenshot).
#include <gtest/gtest.h>

#include <cstdlib>

#include "cli_test_util.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Software WebGL (SwiftShader) in the GPU process: headless machines have no GPU. Opting in keeps
// Chromium from printing its deprecation warning into the console, and without --disable-gpu the
// compositor does not read the WebGL canvas back (which logs "GPU stall due to ReadPixels").
std::string Chromium(const std::string& flags, const std::string& url) {
  return RunShell(
             "timeout 120 chromium --headless --no-sandbox --enable-unsafe-swiftshader --use-angle=swiftshader "
             "--enable-logging=stderr --log-level=0 " +
             flags + " " + url + " 2>&1")
      .output;
}

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// Two blocks as the demo leaves them: datasets, points (a sphere and a cube shell), a
// registration, renders of block 0 and a training log.
std::string WriteRun(const ScopedTempDir& dir) {
  const std::string run = dir.File("run");
  for (int b = 0; b < 2; ++b) {
    const std::string block = "block_" + std::to_string(b);
    Dataset ds;
    for (int k = 0; k < 4; ++k) {
      Frame f;
      f.name = "r_00" + std::to_string(k) + ".png";
      f.file_path = "images/" + f.name;
      f.camera = Camera::Pinhole(16, 16, 16, 16, 8, 8);
      const double a = 1.5 * k;
      // Cameras on a circle of radius 3 looking at the origin (OpenCV axes: +z forward).
      const Eigen::Vector3d centre(3 * std::sin(a), 0, -3 * std::cos(a));
      const Eigen::Vector3d z = -centre.normalized(), y(0, 1, 0), x = y.cross(z);
      Eigen::Matrix3d world_from_cam;
      world_from_cam << x, y, z;
      f.cam_from_world = Rigid3d(world_from_cam.transpose(), -world_from_cam.transpose() * centre);
      ds.frames.push_back(f);
      Image gt(16, 16, 3);
      for (size_t i = 0; i < gt.data.size(); ++i) gt.data[i] = float((i * 7 + k) % 11) / 11.f;
      WriteImage(run + "/data/" + block + "/" + f.file_path, gt);
      if (b == 0) {
        for (float& v : gt.data) v = 0.9f * v + 0.05f;
        WriteImage(run + "/renders_block_0/" + f.name, gt);
      }
    }
    WriteTransformsJson(ds, run + "/data/" + block + "/transforms.json");
    std::string ply =
        "ply\nformat ascii 1.0\nelement vertex 2000\nproperty float x\nproperty float y\nproperty float z\n"
        "end_header\n";
    for (int i = 0; i < 2000; ++i) {
      const double u = i * 0.61803398875, v = (i + 0.5) / 2000.0;
      const double th = std::acos(1 - 2 * v), ph = 2 * M_PI * u;
      ply += std::to_string(std::sin(th) * std::cos(ph) + b) + " " + std::to_string(std::sin(th) * std::sin(ph)) + " " +
             std::to_string(std::cos(th)) + "\n";
    }
    WriteFileAtomic(run + "/" + block + ".ply", ply);
  }
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t(0, 3) = 1;
  WriteJsonFile(run + "/target_from_source_auto.json", Json{{"target_from_source", MatrixToJson(t)},
                                                            {"method", "auto"},
                                                            {"seconds", 2.5},
                                                            {"confidence", 0.8},
                                                            {"source", run + "/block_0.ckpt"},
                                                            {"target", run + "/block_1.ckpt"}});
  WriteJsonFile(run + "/errors_auto.json",
                Json{{"rotation_error_deg", 0.5}, {"translation_error", 0.01}, {"translation_error_fraction", 0.004}});
  WriteImage(run + "/target_from_source_auto_before.png", Image(30, 10, 3, 0.9f));
  WriteImage(run + "/target_from_source_auto_after.png", Image(30, 10, 3, 0.8f));
  WriteFileAtomic(
      run + "/block_0.ckpt.log.jsonl",
      "{\"step\": 50, \"loss\": 0.1}\n{\"step\": 100, \"loss\": 0.01, \"test_psnr\": 21, \"seconds\": 3}\n");
  return run;
}

TEST(ReportChromium, ConsoleErrorsAreDetected) {
  // Guards the check below: a page with a script error must be caught by this harness.
  if (!HaveProgram("chromium")) GTEST_SKIP() << "chromium not installed";
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("bad.html"), "<html><body><script>undefinedFn();</script></body></html>");
  EXPECT_NE(Chromium("--dump-dom", "file://" + dir.File("bad.html")).find("CONSOLE"), std::string::npos);
}

TEST(ReportChromium, ReportRendersWithoutConsoleErrorsAndDrawsThe3dView) {
  if (!HaveProgram("chromium")) GTEST_SKIP() << "chromium not installed";
  if (!FileExists("/usr/share/javascript/three/three.min.js")) GTEST_SKIP() << "libjs-three not installed";
  ScopedTempDir dir;
  const std::string run = WriteRun(dir);
  const CommandResult r = RunNerfreg("report " + run + " --out " + dir.File("report.html"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string out = Chromium("--dump-dom", "file://" + dir.File("report.html"));
  EXPECT_EQ(out.find("CONSOLE"), std::string::npos) << out.substr(0, 3000);
  // Overlays, renders, ground truth and heat-maps decoded into the DOM; curves drawn.
  EXPECT_EQ(Count(out, "<img"), 2u + 3u * 4u);
  EXPECT_NE(out.find("<polyline"), std::string::npos);
  // Two views in the registration view: the WebGL read-back after the first frame found points.
  const size_t at = out.find("data-drawn-pixels=\"");
  ASSERT_NE(at, std::string::npos) << "the 3D view did not draw";
  EXPECT_GT(std::atoi(out.c_str() + at + 19), 2000);

  // A screenshot: the canvas (its dark background) holds drawn pixels.
  const std::string shot = dir.File("shot.png");
  Chromium("--hide-scrollbars --window-size=1280,2400 --screenshot=" + shot, "file://" + dir.File("report.html"));
  ASSERT_TRUE(FileExists(shot));
  const Image im = ReadImage(shot, 3);
  auto is_bg = [&](int x, int y) {
    return std::abs(im.at(x, y, 0) * 255 - 0x15) < 2 && std::abs(im.at(x, y, 1) * 255 - 0x18) < 2 &&
           std::abs(im.at(x, y, 2) * 255 - 0x1e) < 2;
  };
  int x0 = im.width, y0 = im.height, x1 = -1, y1 = -1;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      if (is_bg(x, y)) {
        x0 = std::min(x0, x);
        y0 = std::min(y0, y);
        x1 = std::max(x1, x);
        y1 = std::max(y1, y);
      }
  ASSERT_GT(x1 - x0, 300) << "no 3D view canvas in the screenshot";
  int drawn = 0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) drawn += !is_bg(x, y);
  EXPECT_GT(drawn, 2000) << "canvas " << x0 << "," << y0 << " - " << x1 << "," << y1;
}

}  // namespace
}  // namespace nerfreg
