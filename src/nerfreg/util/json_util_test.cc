#include "nerfreg/util/json_util.h"

#include <gtest/gtest.h>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(JsonUtil, NestingIsBoundedWithANamedError) {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  EXPECT_NE(InputErrorOf([&] {
              ParseJson(deep, "deep.json");
            }).find("deep.json: expected JSON nested at most 64 levels deep"),
            std::string::npos);
  const std::string ok = std::string(kMaxJsonDepth, '[') + std::string(kMaxJsonDepth, ']');
  EXPECT_EQ(InputErrorOf([&] { ParseJson(ok, "ok.json"); }), "");
  EXPECT_NE(InputErrorOf([] { ParseJson("{\"a\": [1,", "t.json"); }).find("t.json: expected valid JSON"),
            std::string::npos);
}

TEST(JsonUtil, ErrorsNameFileAndFieldPath) {
  const Json j = Json::parse(R"({"frames": [{"transform_matrix": [[1,0,0],[0,1,0]]}]})");
  const JsonField root(j, "t.json");
  const std::string msg = InputErrorOf([&] { root["frames"][0]["transform_matrix"].Matrix(4, 4); });
  EXPECT_NE(msg.find("t.json: frames[0].transform_matrix: expected a 4x4 matrix"), std::string::npos) << msg;
  EXPECT_NE(InputErrorOf([&] { root["camera_angle_x"]; }).find("camera_angle_x"), std::string::npos);
  EXPECT_NE(InputErrorOf([&] { root["frames"][3]; }).find("frames"), std::string::npos);
}

TEST(JsonUtil, MatrixAndOptionals) {
  const Json j = Json::parse(R"({"m": [[1,2],[3,4]], "a": 2.5})");
  const JsonField root(j, "x.json");
  const Eigen::MatrixXd m = root["m"].Matrix(2, 2);
  EXPECT_EQ(m(1, 0), 3);
  EXPECT_EQ(root.DoubleOr("a", 1.0), 2.5);
  EXPECT_EQ(root.DoubleOr("b", 1.0), 1.0);
  EXPECT_EQ(MatrixToJson(m), j["m"]);
}

TEST(JsonUtil, TruncatedFileIsAnInputError) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("t.json"), R"({"frames": [)");
  const std::string msg = InputErrorOf([&] { ReadJsonFile(dir.File("t.json")); });
  EXPECT_NE(msg.find("t.json: expected valid JSON"), std::string::npos) << msg;
  // A number that overflows a double (a fuzzer finding: nlohmann throws out_of_range).
  WriteFileAtomic(dir.File("n.json"), R"({"w": 6777477777777777E77777777777388888888888888})");
  EXPECT_NE(InputErrorOf([&] { ReadJsonFile(dir.File("n.json")); }).find("n.json"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
