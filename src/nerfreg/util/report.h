#pragma once
// Building blocks of the HTML run report (pipeline/run_report.h writes the page): escaping,
// base64 for data: URIs, training curves read from `*.jsonl` logs and drawn as inline SVG charts
// (no scripts, no external resources).
#include <string>
#include <vector>

#include "nerfreg/util/json_util.h"

namespace nerfreg {

// One series of a training curve.
struct CurveSeries {
  std::string name;
  std::vector<double> x;
  std::vector<double> y;
};

struct ChartAxes {
  std::string x_label = "step";
  std::string y_label;
  bool log_y = false;  // decades on the y axis; non-positive values are left out
};

// Inline SVG line chart with labelled, ticked axes and a legend.
std::string SvgLineChart(const std::string& title, const std::vector<CurveSeries>& series, const ChartAxes& axes = {},
                         int width = 560, int height = 280);

// True when every finite y is positive and they span more than `min_ratio` (max / min): a loss
// falling over decades reads better on a log axis, a PSNR does not.
bool PreferLogScale(const std::vector<CurveSeries>& series, double min_ratio = 20);

// Reads `*.jsonl` log lines into one series per numeric metric (x = "step").
// Malformed lines are skipped (a log being written while we read may end mid-line).
std::vector<CurveSeries> ReadCurves(const std::string& jsonl_path);

std::string HtmlEscape(const std::string& text);
std::string Base64Encode(const std::string& bytes);

}  // namespace nerfreg
