#include "nerfreg/util/report.h"

#include <gtest/gtest.h>

#include "nerfreg/util/file_util.h"
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

TEST(Report, LogScaleOnlyForPositiveCurvesSpanningDecades) {
  CurveSeries loss{"loss", {1, 2, 3}, {1.0, 0.1, 0.01}};
  CurveSeries psnr{"psnr", {1, 2, 3}, {18, 24, 29}};
  CurveSeries signed_values{"x", {1, 2}, {-1, 100}};
  EXPECT_TRUE(PreferLogScale({loss}));
  EXPECT_FALSE(PreferLogScale({psnr}));
  EXPECT_FALSE(PreferLogScale({signed_values}));
}

TEST(Report, ChartHasLabelledAxesAndDecadeTicks) {
  const CurveSeries loss{"loss", {0, 500, 1000}, {1.0, 0.05, 0.002}};
  const std::string svg = SvgLineChart("block_0: loss", {loss}, ChartAxes{"step", "loss", true});
  EXPECT_NE(svg.find(">step</text>"), std::string::npos);
  EXPECT_NE(svg.find(">loss (log scale)</text>"), std::string::npos);
  // Decade ticks 0.01, 0.1 and 1 on the y axis; round ticks on the x axis.
  EXPECT_NE(svg.find(">0.01</text>"), std::string::npos);
  EXPECT_NE(svg.find(">0.1</text>"), std::string::npos);
  EXPECT_NE(svg.find(">1</text>"), std::string::npos);
  EXPECT_NE(svg.find(">1000</text>"), std::string::npos);
  // The smallest value sits at the bottom of the plot: log10 spacing, not linear.
  const std::string linear = SvgLineChart("loss", {loss}, ChartAxes{"step", "loss", false});
  EXPECT_NE(svg, linear);
  EXPECT_EQ(linear.find("log scale"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
