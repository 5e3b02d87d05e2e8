// reg eval --pair on a result of known error: the rotation, translation and scale errors read back,
// and a result registered the other way (block 1 -> 0 scored as 0 -> 1) flagged, not only failed.
#include "nerfreg/pipeline/evaluate_pairs.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Two blocks at scales 1.62 and 0.66 (relative 0.41 and 2.46: bench/registration_sim3.sh's
// block set 6000:16), each in its own frame.
const Sim3d kBlock0FromWorld(1.62, Eigen::Quaterniond(Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, 2, -1).normalized())),
                             Eigen::Vector3d(0.2, -0.2, 0.02));
const Sim3d kBlock1FromWorld(0.66, Eigen::Quaterniond(Eigen::AngleAxisd(2.1, Eigen::Vector3d(-1, 0, 3).normalized())),
                             Eigen::Vector3d(0.2, -0.2, 0.2));

class EvaluatePair : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteJsonFile(dir_.File("gt.json"), {{"blocks",
                                          {{{"block_from_world", MatrixToJson(kBlock0FromWorld.ToMatrix())}},
                                           {{"block_from_world", MatrixToJson(kBlock1FromWorld.ToMatrix())}}}}});
  }
  // A result of block 1 -> block 0, `deg` off about z.
  std::string WriteOneToZero(double deg) {
    const Sim3d off(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(deg * M_PI / 180, Eigen::Vector3d::UnitZ())),
                    Eigen::Vector3d::Zero());
    const Sim3d t = off * kBlock0FromWorld * kBlock1FromWorld.Inverse();
    WriteJsonFile(dir_.File("t.json"), {{"target_from_source", MatrixToJson(t.ToMatrix())}, {"method", "test"}});
    return dir_.File("t.json");
  }
  ScopedTempDir dir_;
};

TEST_F(EvaluatePair, ScoresEachDirectionAgainstItsOwnTruth) {
  const std::string t = WriteOneToZero(1.0);
  const RegistrationError right = EvaluateRegistrationFile(t, dir_.File("gt.json"), 1, 0, dir_.File("err.json"));
  EXPECT_NEAR(right.rotation_deg, 1.0, 1e-6);
  EXPECT_TRUE(right.success);
  EXPECT_FALSE(right.matches_swapped);
  EXPECT_NEAR(right.true_scale, 1.62 / 0.66, 1e-9);
  EXPECT_NEAR(right.scale_error, 0, 1e-9);
  EXPECT_NEAR(ReadJsonFile(dir_.File("err.json"))["scale"].get<double>(), 1.62 / 0.66, 1e-9);
  // The same result scored as 0 -> 1 (reg eval's default blocks): wrong, and said to be the other way.
  const RegistrationError swapped = EvaluateRegistrationFile(t, dir_.File("gt.json"), 0, 1);
  EXPECT_GT(swapped.rotation_deg, 20);
  EXPECT_FALSE(swapped.success);
  EXPECT_TRUE(swapped.matches_swapped);
  EXPECT_NEAR(swapped.scale_error, std::pow(1.62 / 0.66, 2) - 1, 1e-9);
  // A wrong pose of the right direction is wrong, not swapped.
  const RegistrationError wrong = EvaluateRegistrationFile(WriteOneToZero(40.0), dir_.File("gt.json"), 1, 0);
  EXPECT_NEAR(wrong.rotation_deg, 40.0, 1e-6);
  EXPECT_FALSE(wrong.success);
  EXPECT_FALSE(wrong.matches_swapped);
}

}  // namespace
}  // namespace nerfreg
