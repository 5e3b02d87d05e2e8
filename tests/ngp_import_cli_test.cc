// `nerf import` end to end: an instant-ngp snapshot (.ingp) with its transforms.json becomes a
// block that `nerf render` renders from those cameras; `reg register` takes the snapshot itself.
#include <gtest/gtest.h>

#include <filesystem>

#include "cli_test_util.h"
#include "nerfreg/data/ngp_test_snapshot.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/reg/registration_input.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(NgpImportCli, ImportThenRender) {
  ScopedTempDir dir;
  const TestNgpSnapshot t = MakeTestNgpSnapshot();
  WriteTestNgpSnapshot(t.json, dir.File("scene.ingp"), true);
  // Two cameras 6 units from the origin of the transforms.json frame, looking at it (OpenGL axes).
  WriteFileAtomic(dir.File("transforms.json"), R"({"fl_x": 20, "fl_y": 20, "cx": 8, "cy": 8, "w": 16, "h": 16,
    "scale": 0.25, "offset": [0.5, 0.4, 0.6], "frames": [
    {"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,6],[0,0,0,1]]},
    {"file_path": "b.png", "transform_matrix": [[0,0,1,6],[0,1,0,0],[-1,0,0,0],[0,0,0,1]]}]})");
  const std::string import = "nerf import " + dir.File("scene.ingp") + " --transforms " + dir.File("transforms.json") +
                             " --out " + dir.File("b.ckpt") + " --quiet";
  const CommandResult r = RunNerfreg(import);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  NerfBlock block = LoadNerfBlock(dir.File("b.ckpt"));
  EXPECT_EQ(block.field_options.flavor, "instant-ngp");
  EXPECT_EQ(block.cameras.frames.size(), 2u);
  EXPECT_GT(block.grid->OccupiedFraction(), 0.0);
  // An existing output is refused without --force.
  const CommandResult again = RunNerfreg(import);
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.output.find("exists; pass --force"), std::string::npos);

  const CommandResult render = RunNerfreg("nerf render " + dir.File("b.ckpt") + " --transforms " +
                                          dir.File("transforms.json") + " --out " + dir.File("renders") + " --quiet");
  ASSERT_EQ(render.exit_code, 0) << render.output;
  int non_white = 0;
  for (const char* name : {"a.png", "b.png"}) {
    const Image im = ReadImage(dir.File(std::string("renders/") + name));
    EXPECT_EQ(im.width, 16);
    EXPECT_EQ(im.height, 16);
    for (float v : im.data) non_white += v < 0.99f;
  }
  EXPECT_GT(non_white, 0);  // the occupied region is seen

  // reg register reads the snapshot itself, imported as above, in the transforms.json's frame: the
  // same occupied points as the imported block's (not ngp's unit cube, 4x larger and shifted).
  const auto direct = LoadRegistrationInput(dir.File("scene.ingp"), SplatFieldOptions());
  NerfBlockInput imported(LoadNerfBlock(dir.File("b.ckpt")));
  EXPECT_EQ(direct->Kind(), "nerf");
  const Eigen::Matrix3Xd a = direct->OccupiedPoints(0, 3), b = imported.OccupiedPoints(0, 3);
  ASSERT_GT(a.cols(), 0);
  ASSERT_EQ(a.cols(), b.cols());
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9);
  const CommandResult reg =
      RunNerfreg("reg register " + dir.File("scene.ingp") + " " + dir.File("b.ckpt") +
                 " --method ransac --refine icp --scale fixed --min-density 0 --quiet --out " + dir.File("t.json"));
  EXPECT_NE(reg.exit_code, 2) << reg.output;
  EXPECT_EQ(ReadJsonFile(dir.File("t.json"))["source_kind"], "nerf") << reg.output;
}

}  // namespace
}  // namespace nerfreg
