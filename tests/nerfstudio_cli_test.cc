// nerfreg convert to and from nerfstudio's transforms.json: the camera model and distortion,
// applied_transform and dataparser_transforms.json survive; bad files are one named error line.
#include <gtest/gtest.h>

#include "cli_test_util.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

const char* kFisheye = R"({
  "camera_model": "OPENCV_FISHEYE", "fl_x": 300, "fl_y": 301, "cx": 320, "cy": 240, "w": 640, "h": 480,
  "k1": 0.05, "k2": -0.01, "k3": 0.002, "k4": -0.0005,
  "applied_transform": [[0,1,0,0],[1,0,0,0],[0,0,-1,0]],
  "test_filenames": ["images/b.jpg"],
  "frames": [
    {"file_path": "images/a.jpg", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
    {"file_path": "images/b.jpg", "transform_matrix": [[0,0,1,4],[0,1,0,0],[-1,0,0,0],[0,0,0,1]]}
  ]})";

TEST(NerfstudioCli, ConvertsToColmapAndBackKeepingTheFisheyeAndTheTransforms) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("ns/transforms.json"), kFisheye);
  WriteFileAtomic(dir.File("ns/dataparser_transforms.json"),
                  R"({"transform": [[1,0,0,0.5],[0,1,0,0],[0,0,1,0]], "scale": 0.25})");
  CommandResult r = RunNerfreg("convert " + dir.File("ns") + " --to nerfstudio --out " + dir.File("copy"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json copy = ReadJsonFile(dir.File("copy/transforms.json"));
  EXPECT_EQ(copy["camera_model"], "OPENCV_FISHEYE");
  EXPECT_DOUBLE_EQ(copy["k4"].get<double>(), -0.0005);
  EXPECT_EQ(copy["applied_transform"][2][2].get<double>(), -1);
  EXPECT_EQ(copy["test_filenames"], Json::array({"../ns/images/b.jpg"}));
  EXPECT_EQ(copy["frames"][1]["file_path"], "../ns/images/b.jpg");
  EXPECT_DOUBLE_EQ(ReadJsonFile(dir.File("copy/dataparser_transforms.json"))["scale"].get<double>(), 0.25);

  // COLMAP has the fisheye model; the round trip keeps intrinsics and poses.
  r = RunNerfreg("convert " + dir.File("copy/transforms.json") + " --to colmap --out " + dir.File("sparse"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(ReadFileToString(dir.File("sparse/cameras.txt")).find("OPENCV_FISHEYE 640 480 300 301 320 240 "),
            std::string::npos);
  r = RunNerfreg("convert " + dir.File("sparse") + " --to nerfstudio --out " + dir.File("back/transforms.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json back = ReadJsonFile(dir.File("back/transforms.json"));
  EXPECT_EQ(back["camera_model"], "OPENCV_FISHEYE");
  EXPECT_DOUBLE_EQ(back["k3"].get<double>(), 0.002);
  const auto m = back["frames"][1]["transform_matrix"];
  EXPECT_NEAR(m[0][3].get<double>(), 4, 1e-9);
  EXPECT_NEAR(m[2][0].get<double>(), -1, 1e-9);
}

TEST(NerfstudioCli, BadFilesAreOneNamedErrorLineAndExitTwo) {
  ScopedTempDir dir;
  std::string bad = kFisheye;
  bad.replace(bad.find("OPENCV_FISHEYE"), 14, "EQUIRECTANGULAR");
  WriteFileAtomic(dir.File("bad/transforms.json"), bad);
  CommandResult r = RunNerfreg("convert " + dir.File("bad") + " --to nerfstudio --out " + dir.File("out"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(r.output, "error: " + dir.File("bad/transforms.json") +
                          ": camera_model: expected PINHOLE, OPENCV or OPENCV_FISHEYE, got EQUIRECTANGULAR\n");
  EXPECT_FALSE(FileExists(dir.File("out/transforms.json")));

  WriteFileAtomic(dir.File("ok/transforms.json"), kFisheye);
  WriteFileAtomic(dir.File("ok/dataparser_transforms.json"), R"({"transform": [[1,0,0,0],[0,1,0,0]], "scale": 1})");
  r = RunNerfreg("convert " + dir.File("ok") + " --to nerfstudio --out " + dir.File("out"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(r.output.rfind("error: " + dir.File("ok/dataparser_transforms.json") + ": transform: expected", 0), 0u)
      << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
}

}  // namespace
}  // namespace nerfreg
