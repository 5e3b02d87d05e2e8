// The HTML report opens in headless Chromium with no console errors and shows its images.
#include <gtest/gtest.h>

#include "cli_test_util.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

std::string Chromium(const std::string& flags, const std::string& url) {
  return RunShell("timeout 90 chromium --headless --no-sandbox --disable-gpu --enable-logging=stderr "
                  "--log-level=0 " + flags + " " + url)
      .output;
}

TEST(ReportChromium, ConsoleErrorsAreDetected) {
  // Guards the check below: a page with a script error must be caught by this harness.
  if (!HaveProgram("chromium")) GTEST_SKIP() << "chromium not installed";
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("bad.html"), "<html><body><script>undefinedFn();</script></body></html>");
  EXPECT_NE(Chromium("--dump-dom", "file://" + dir.File("bad.html")).find("CONSOLE"), std::string::npos);
}

TEST(ReportChromium, ReportRendersWithoutConsoleErrors) {
  if (!HaveProgram("chromium")) GTEST_SKIP() << "chromium not installed";
  ScopedTempDir dir;
  const std::string run = dir.File("run");
  Image im(16, 16, 3);
  for (size_t i = 0; i < im.data.size(); ++i) im.data[i] = float(i % 7) / 7.f;
  WriteImage(run + "/renders/r_000.png", im);
  WriteImage(run + "/renders/r_001.png", im);
  WriteFileAtomic(run + "/metrics.json", R"({"psnr": 27.5})");
  WriteFileAtomic(run + "/train_log.jsonl", "{\"step\": 1, \"loss\": 1}\n{\"step\": 2, \"loss\": 0.5}\n");
  const CommandResult r = RunNerfreg("report " + run + " --out " + dir.File("report.html"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string out = Chromium("--dump-dom", "file://" + dir.File("report.html"));
  EXPECT_EQ(out.find("CONSOLE"), std::string::npos) << out.substr(0, 2000);
  // Both images decoded by the browser made it into the DOM, and the curve is there.
  size_t imgs = 0;
  for (size_t p = out.find("<img"); p != std::string::npos; p = out.find("<img", p + 1)) ++imgs;
  EXPECT_EQ(imgs, 2u);
  EXPECT_NE(out.find("<polyline"), std::string::npos);
  EXPECT_NE(out.find("27.5"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
