// The bad-input battery: each case is a broken input, the command run on it, and the message
// class it must produce. A case passes when the command exits 2 with a one-line error naming the
// file (and field), leaves no output behind, and does not crash (exit 3 or a signal fails it).
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>

#include "cli_test_util.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

struct BadInputCase {
  const char* name;
  // Writes the broken input into dir; returns the nerfreg arguments (may use dir).
  std::function<std::string(const std::string& dir)> setup;
  const char* expected;  // substring of the error line, after "error: "
  const char* output;    // output path (relative to dir) that must not exist afterwards, or ""
};

const std::vector<BadInputCase>& Cases() {
  static const std::vector<BadInputCase> cases = {
      {"report_missing_run_dir",
       [](const std::string& d) { return "report " + d + "/nope --out " + d + "/r.html"; },
       "nope: expected a run directory", "r.html"},
      {"report_existing_output_without_force",
       [](const std::string& d) {
         CreateDirectories(d + "/run");
         WriteFileAtomic(d + "/r.html", "old");
         return "report " + d + "/run --out " + d + "/r.html";
       },
       "r.html: exists; pass --force to overwrite", ""},
      {"unknown_option", [](const std::string& d) { return "report " + d + " --out " + d + "/r.html --no-such-option"; },
       "no-such-option", "r.html"},
  };
  return cases;
}

class BadInput : public ::testing::TestWithParam<size_t> {};

TEST_P(BadInput, FailsCleanlyWithANamedError) {
  const BadInputCase& c = Cases()[GetParam()];
  ScopedTempDir dir;
  const std::string args = c.setup(dir.path());
  const CommandResult r = RunNerfreg(args);
  EXPECT_EQ(r.exit_code, 2) << c.name << ": " << r.output;
  EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.name << ": " << r.output;
  if (*c.output) EXPECT_FALSE(std::filesystem::exists(dir.File(c.output))) << c.name;
  // No temp files left anywhere under the test dir.
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  }
}

INSTANTIATE_TEST_SUITE_P(Battery, BadInput, ::testing::Range<size_t>(0, Cases().size()),
                         [](const ::testing::TestParamInfo<size_t>& info) { return std::string(Cases()[info.param].name); });

}  // namespace
}  // namespace nerfreg
