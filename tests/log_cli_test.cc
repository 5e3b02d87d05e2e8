// The logging contract of every command, end to end: --json makes every stderr line one JSON
// object (log lines with time / level / msg, progress lines with done / total / rate / elapsed_s /
// eta_s), --quiet prints no progress and no info, and every subcommand's --help shows an example.
#include <gtest/gtest.h>

#include <algorithm>
#include <future>

#include <filesystem>
#include <sstream>
#include <vector>

#include "cli_test_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Runs nerfreg with `args`, returning its stderr alone (stdout dropped).
CommandResult RunNerfregStderr(const std::string& args) {
  return RunShell(std::string("(") + NERFREG_BINARY + " " + args + " 2>&1 >/dev/null)");
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(line);
  return lines;
}

TEST(LogCli, JsonMakesEveryStderrLineAJsonObjectWithProgressRateAndEta) {
  ScopedTempDir dir;
  // A quote and a backslash in the output path, which the info line names: they must be escaped.
  const std::string out = dir.File("scene \"q\" \\b");
  const CommandResult r =
      RunNerfregStderr("render --procedural 3 --trajectory forward --views 4 --size 32x24 --json --out '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  int log_lines = 0, progress_lines = 0;
  bool saw_out_path = false;
  for (const std::string& line : Lines(r.output)) {
    Json j;
    ASSERT_NO_THROW(j = Json::parse(line)) << "not JSON: " << line;
    ASSERT_TRUE(j.is_object()) << line;
    if (j.contains("progress")) {
      ++progress_lines;
      EXPECT_EQ(j["progress"], "render") << line;
      for (const char* key : {"done", "total", "rate", "elapsed_s"})
        ASSERT_TRUE(j[key].is_number()) << key << ": " << line;
      EXPECT_EQ(j["total"].get<int>(), 4) << line;
      EXPECT_GE(j["rate"].get<double>(), 0) << line;
      if (j["done"].get<int>() == 4) {
        ASSERT_TRUE(j["eta_s"].is_number()) << line;  // known once anything is done
        EXPECT_EQ(j["eta_s"].get<double>(), 0) << line;
        EXPECT_GT(j["rate"].get<double>(), 0) << line;
      }
    } else {
      ++log_lines;
      for (const char* key : {"time", "level", "msg"}) ASSERT_TRUE(j[key].is_string()) << key << ": " << line;
      saw_out_path |= j["msg"].get<std::string>().find(out) != std::string::npos;
    }
  }
  EXPECT_GE(progress_lines, 1) << r.output;
  EXPECT_GE(log_lines, 1) << r.output;
  EXPECT_TRUE(saw_out_path) << r.output;  // the path came back intact through the escaping
  EXPECT_TRUE(std::filesystem::exists(out + "/transforms.json"));
}

TEST(LogCli, QuietPrintsNoProgressAndNoInfo) {
  ScopedTempDir dir;
  const CommandResult plain =
      RunNerfregStderr("render --procedural 3 --trajectory forward --views 4 --size 32x24 --out " + dir.File("a"));
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_NE(plain.output.find("ETA"), std::string::npos) << plain.output;  // the bar, without --quiet
  int k = 0;
  for (const char* flag : {"--quiet", "--quiet --json"}) {
    const CommandResult r = RunNerfregStderr("render --procedural 3 --trajectory forward --views 4 --size 32x24 " +
                                             std::string(flag) + " --out " + dir.File("b" + std::to_string(k++)));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.output, "") << flag;
  }
}

TEST(LogCli, EverySubcommandsHelpShowsAnExample) {
  // The commands as `nerfreg --help` lists them ("  NAME<padding> summary"), so commands added
  // later are covered without editing this test.
  const CommandResult list = RunNerfreg("--help");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  std::vector<std::string> names;
  bool in_commands = false;
  for (const std::string& line : Lines(list.output)) {
    if (line == "Commands:") {
      in_commands = true;
      continue;
    }
    if (!in_commands || line.rfind("  ", 0) != 0) continue;
    std::string name = line.substr(2, 22);
    name = name.substr(0, name.find_last_not_of(' ') + 1);
    names.push_back(name);
  }
  ASSERT_GE(names.size(), 15u) << list.output;
  // Four at a time: each run is mostly the binary's start-up (loading LibTorch), not work.
  std::vector<CommandResult> results(names.size());
  for (size_t start = 0; start < names.size(); start += 4) {
    std::vector<std::future<CommandResult>> batch;
    for (size_t i = start; i < std::min(names.size(), start + 4); ++i) {
      batch.push_back(std::async(std::launch::async, [&names, i] { return RunNerfreg(names[i] + " --help"); }));
    }
    for (size_t k = 0; k < batch.size(); ++k) results[start + k] = batch[k].get();
  }
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    const CommandResult& r = results[i];
    EXPECT_EQ(r.exit_code, 0) << name << ": " << r.output;
    const size_t example = r.output.find("Example:");
    ASSERT_NE(example, std::string::npos) << name << ": " << r.output;
    EXPECT_NE(r.output.find("nerfreg " + name + " ", example), std::string::npos) << name << ": " << r.output;
  }
}

}  // namespace
}  // namespace nerfreg
