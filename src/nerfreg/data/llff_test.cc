#include "nerfreg/data/llff.h"

#include <gtest/gtest.h>

#include "nerfreg/data/npy.h"
#include "nerfreg/data/test_data.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(Llff, RoundTripThroughPosesBounds) {
  ScopedTempDir dir;
  const Dataset d = MakeRingDataset(dir.path(), 9, false, true);
  WriteLlffPoses(d, dir.path());
  LlffOptions opt;
  opt.test_every = 8;
  const Dataset back = ReadLlff(dir.path(), opt);
  ExpectSamePoses(d, back);
  EXPECT_DOUBLE_EQ(back.frames[3].near, 2.0);
  EXPECT_DOUBLE_EQ(back.frames[3].far, 6.0);
  EXPECT_EQ(back.frames[0].split, "test");
  EXPECT_EQ(back.frames[8].split, "test");
  EXPECT_EQ(back.frames[1].split, "train");
}

TEST(Llff, DownsampledImageFolderRescalesFocal) {
  ScopedTempDir dir;
  Dataset d = MakeRingDataset(dir.path(), 3, false, true);
  WriteLlffPoses(d, dir.path());
  for (const auto& f : d.frames) WriteImage(dir.File("images_2/" + f.name), Image(12, 8, 3));
  LlffOptions opt;
  opt.image_dir = "images_2";
  const Dataset half = ReadLlff(dir.path(), opt);
  EXPECT_DOUBLE_EQ(half.frames[0].camera.fx, 10.0);
  EXPECT_EQ(half.frames[0].camera.width, 12);
}

TEST(Llff, CamerasLlffCannotStoreAreRefused) {
  ScopedTempDir dir;
  const Dataset off_centre = MakeRingDataset(dir.path(), 2);
  EXPECT_THROW(WriteLlffPoses(off_centre, dir.File("out")), InputError);
  Dataset distorted = MakeRingDataset(dir.path(), 2, true, true);
  EXPECT_THROW(WriteLlffPoses(distorted, dir.File("out")), InputError);
}

TEST(Llff, MismatchedImageCountAndBadShapeAreNamed) {
  ScopedTempDir dir;
  const Dataset d = MakeRingDataset(dir.path(), 4, false, true);
  WriteLlffPoses(d, dir.path());
  WriteImage(dir.File("images/zz_extra.png"), Image(24, 16, 3));
  try {
    ReadLlff(dir.path());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("4 images as poses_bounds.npy has rows, found 5"), std::string::npos)
        << e.what();
  }
  NpyArray bad;
  bad.shape = {2, 15};
  bad.data.assign(30, 1.0);
  WriteNpy(dir.File("poses_bounds.npy"), bad);
  EXPECT_THROW(ReadLlff(dir.path()), InputError);
}

}  // namespace
}  // namespace nerfreg
