// `nerfreg dbarf poses` and `dbarf eval-poses` end to end, as a user runs them: a rendered
// forward-facing scene, its images posed from the pixels and the intrinsics alone, then evaluated
// against the renderer's ground truth.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "cli_test_util.h"
#include "nerfreg/data/colmap.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(DbarfCli, PosesARenderedForwardFacingSceneAndEvaluatesThem) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene"), out = dir.File("poses");
  CommandResult r = RunNerfreg("render --procedural 5 --trajectory forward --views 10 --quiet --out " + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunNerfreg("dbarf poses " + data + "/images --intrinsics " + data + "/transforms.json --quiet --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Dataset est = ReadTransformsJson(out + "/transforms.json");
  ASSERT_EQ(est.frames.size(), 10u);
  CheckImagesMatchCameras(est);  // file_path resolves from OUT to the images
  EXPECT_EQ(est.frames[3].name, "r_003.png");
  const Json j = ReadJsonFile(out + "/transforms.json");
  EXPECT_TRUE(j["not_posed"].empty());
  const ColmapModel model = ReadColmapModel(out + "/sparse/0");
  EXPECT_EQ(model.images.size(), 10u);
  EXPECT_GT(model.points3d.size(), 100u);

  // Aligned on rotations then centres: with centres this close, a centre-only Umeyama fit adds
  // ~1 deg of its own (measured here: 0.08 deg after the rotation fit, 1.1 deg after Umeyama).
  r = RunNerfreg("dbarf eval-poses " + out + "/transforms.json --ground-truth " + data + "/transforms.json --align rotations --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json e = Json::parse(r.output.substr(r.output.find('{')));
  EXPECT_EQ(e["posed"].get<int>(), 10);
  EXPECT_LT(e["rotation_deg_median"].get<double>(), 0.5) << r.output;
  EXPECT_LT(e["center_percent_median"].get<double>(), 2.0) << r.output;

  // An existing output is refused without --force, replaced with it; --focal works too.
  r = RunNerfreg("dbarf poses " + data + "/images --focal 140.8 --quiet --out " + out);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
  r = RunNerfreg("dbarf poses " + data + "/images --focal 140.8 --quiet --force --out " + out);
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(DbarfCli, TooFewImagesIsAOneLineErrorNamingTheFolder) {
  ScopedTempDir dir;
  const std::string data = dir.File("scene");
  ASSERT_EQ(RunNerfreg("render --procedural 2 --trajectory forward --views 2 --quiet --out " + data).exit_code, 0);
  const CommandResult r = RunNerfreg("dbarf poses " + data + "/images --focal 100 --out " + dir.File("o"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(data + "/images"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("o")));
}

}  // namespace
}  // namespace nerfreg
