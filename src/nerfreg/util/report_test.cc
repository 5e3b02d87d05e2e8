#include "nerfreg/util/report.h"

#include <gtest/gtest.h>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(Report, Base64KnownVectors) {
  EXPECT_EQ(Base64Encode(""), "");
  EXPECT_EQ(Base64Encode("f"), "Zg==");
  EXPECT_EQ(Base64Encode("fo"), "Zm8=");
  EXPECT_EQ(Base64Encode("foo"), "Zm9v");
  EXPECT_EQ(Base64Encode("foobar"), "Zm9vYmFy");
}

TEST(Report, CurvesFromJsonlSkipMalformedLines) {
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("log.jsonl"),
                  "{\"step\": 1, \"loss\": 0.5, \"psnr\": 10}\n{\"step\": 2, \"loss\": 0.25}\nnot json\n{\"step\":3,");
  const auto curves = ReadCurves(dir.File("log.jsonl"));
  ASSERT_EQ(curves.size(), 2u);
  EXPECT_EQ(curves[0].name, "loss");
  EXPECT_EQ(curves[0].y, (std::vector<double>{0.5, 0.25}));
  EXPECT_EQ(curves[1].x, (std::vector<double>{1}));
}

TEST(Report, PageEmbedsImagesMetricsAndCurves) {
  ScopedTempDir dir;
  const std::string run = dir.File("run");
  WriteImage(run + "/renders/r_000.png", Image(4, 4, 3, 0.5f));
  WriteFileAtomic(run + "/metrics.json", R"({"psnr": 27.5, "note": "<b>"})");
  WriteFileAtomic(run + "/train_log.jsonl", "{\"step\": 1, \"loss\": 1}\n{\"step\": 2, \"loss\": 0.5}\n");
  WriteFileAtomic(run + "/data/transforms.json", R"({"frames": []})");
  WriteImage(run + "/data/images/r_000.png", Image(4, 4, 3, 0.1f));
  WriteRunReport(run, dir.File("report.html"), ReportOptions{});
  const std::string html = ReadFileToString(dir.File("report.html"));
  // The dataset folder is listed, its files are not embedded: one image only.
  EXPECT_NE(html.find("<code>data</code>"), std::string::npos);
  size_t images = 0;
  for (size_t p = html.find("<img"); p != std::string::npos; p = html.find("<img", p + 1)) ++images;
  EXPECT_EQ(images, 1u);
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
  EXPECT_NE(html.find("27.5"), std::string::npos);
  EXPECT_NE(html.find("&lt;b&gt;"), std::string::npos);  // escaped
  EXPECT_NE(html.find("<polyline"), std::string::npos);
  EXPECT_THROW(WriteRunReport(dir.File("missing"), dir.File("r2.html"), ReportOptions{}), InputError);
}

}  // namespace
}  // namespace nerfreg
