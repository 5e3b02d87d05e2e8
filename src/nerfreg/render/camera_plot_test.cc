#include "nerfreg/render/camera_plot.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nerfreg/geometry/conventions.h"

namespace nerfreg {
namespace {

bool Is(const Image& im, int x, int y, const Eigen::Vector3f& color) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(im.at(x, y, c) - color(c)) > 1e-6f) return false;
  return true;
}

// n cameras on a circle of `radius` in the z = 0 plane, looking at the origin, up +z.
std::vector<Rigid3d> Ring(int n, double radius, const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  std::vector<Rigid3d> cams;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    const Eigen::Vector3d eye(radius * std::cos(a), radius * std::sin(a), 0);
    cams.push_back(LookAt(eye + shift, shift, Eigen::Vector3d::UnitZ()));
  }
  return cams;
}

TEST(CameraPlot, RingOfCamerasIsARingSeenFromAboveWithAScaleBar) {
  CameraPlotOptions o;
  o.size = 256;
  const CameraPlot plot = PlotCamerasFromAbove({{Ring(8, 2.0), kEstimateColor}}, false, o);
  ASSERT_EQ(plot.image.width, 256);
  ASSERT_EQ(plot.image.height, 256);
  ASSERT_EQ(plot.image.channels, 3);
  // Diameter 4 fitted into 256 - 2 * 32 pixels: the ring has radius 96 px about the centre; the
  // viewing-direction lines point inwards by 0.08 * 4 units = 15 px.
  int colored = 0;
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) {
      if (!Is(plot.image, x, y, kEstimateColor)) continue;
      ++colored;
      const double r = std::hypot(x - 128.0, y - 128.0);
      EXPECT_GT(r, 96 - 17) << x << "," << y;
      EXPECT_LT(r, 96 + 6) << x << "," << y;
    }
  EXPECT_GT(colored, 8 * 40);  // 8 discs of radius 4 (49 pixels each, some overlap with lines)
  EXPECT_TRUE(Is(plot.image, 128, 128, Eigen::Vector3f(1, 1, 1)));
  // The scale bar: 1 unit (a quarter of the extent, rounded to 1/2/5), 48 px, in the bottom margin.
  EXPECT_DOUBLE_EQ(plot.scale_bar_length, 1.0);
  const int bar_y = 256 - 16;
  EXPECT_TRUE(Is(plot.image, 32 + 24, bar_y, Eigen::Vector3f::Zero()));
  EXPECT_TRUE(Is(plot.image, 32 + 47, bar_y, Eigen::Vector3f::Zero()));
  EXPECT_FALSE(Is(plot.image, 32 + 60, bar_y, Eigen::Vector3f::Zero()));
}

TEST(CameraPlot, ForwardFacingRowLooksUpThePictureWithWorldRightToTheRight) {
  // Five cameras along world x, looking along +y, up +z: seen from above, a horizontal row whose
  // viewing lines point up the picture, the camera at x = -1 on the left.
  std::vector<Rigid3d> cams;
  for (int k = 0; k < 5; ++k) {
    const Eigen::Vector3d eye(-1 + 0.5 * k, 0, 0);
    cams.push_back(LookAt(eye, eye + Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()));
  }
  CameraPlotOptions o;
  o.size = 200;
  o.margin = 20;
  const CameraPlot plot = PlotCamerasFromAbove({{cams, kGroundTruthColor}}, false, o);
  const Image& im = plot.image;
  EXPECT_TRUE(Is(im, 20, 100, kGroundTruthColor));        // x = -1 at the left margin
  EXPECT_TRUE(Is(im, 180, 100, kGroundTruthColor));       // x = +1 at the right margin
  EXPECT_TRUE(Is(im, 100, 100 - 10, kGroundTruthColor));  // the middle camera's line, upwards
  for (int y = 100 + o.marker_radius + 1; y < 200 - o.margin; ++y)
    for (int x = 0; x < 200; ++x) EXPECT_FALSE(Is(im, x, y, kGroundTruthColor)) << x << "," << y;
}

TEST(CameraPlot, EstimateAgainstGroundTruthDrawsBothColoursAndTheLinks) {
  const std::vector<Rigid3d> gt = Ring(6, 1.0);
  const std::vector<Rigid3d> est = Ring(6, 1.0, Eigen::Vector3d(0.3, 0, 0));
  CameraPlotOptions o;
  o.size = 256;
  const CameraPlot plot = PlotCamerasFromAbove({{est, kEstimateColor}, {gt, kGroundTruthColor}}, true, o);
  int counts[3] = {0, 0, 0};
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) {
      counts[0] += Is(plot.image, x, y, kEstimateColor);
      counts[1] += Is(plot.image, x, y, kGroundTruthColor);
      counts[2] += Is(plot.image, x, y, kLinkColor);
    }
  EXPECT_GT(counts[0], 6 * 30);
  EXPECT_GT(counts[1], 6 * 30);
  // 0.3 units apart at 192 / 2.3 px per unit: 25 px links, about 15 px of each outside the discs.
  EXPECT_GT(counts[2], 6 * 8);
}

TEST(CameraPlot, RefusesNoCamerasMismatchedLinksAndBadOptions) {
  EXPECT_THROW(PlotCamerasFromAbove({}, false), std::invalid_argument);
  EXPECT_THROW(PlotCamerasFromAbove({{Ring(3, 1), kEstimateColor}, {Ring(4, 1), kGroundTruthColor}}, true),
               std::invalid_argument);
  CameraPlotOptions o;
  o.size = 10;
  EXPECT_THROW(o.Check(), std::invalid_argument);
  o = CameraPlotOptions();
  o.direction_length = NAN;
  EXPECT_THROW(o.Check(), std::invalid_argument);
  // A single camera is fine (extent 0 is treated as 1 unit).
  const CameraPlot one = PlotCamerasFromAbove({{Ring(1, 1), kEstimateColor}}, false);
  EXPECT_TRUE(Is(one.image, 256, 256, kEstimateColor));
}

}  // namespace
}  // namespace nerfreg
