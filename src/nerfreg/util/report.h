#pragma once
// A self-contained HTML page for one run directory, so results can be looked at without tools:
// every PNG in the run (embedded as base64, grouped by folder), every JSON file of metrics or
// options (as tables), and training curves drawn as inline SVG from `*.jsonl` logs (one JSON object
// per line with a "step" field and numeric metrics, as the trainers write them).
#include <string>
#include <vector>

#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct ReportOptions {
  std::string title;                 // page title; default: the run directory's name
  int max_images = 200;              // images beyond this are listed, not embedded
  long long max_image_bytes = 8 << 20;  // larger PNGs are listed, not embedded
  void Check() const;
};

// One series of a training curve.
struct CurveSeries {
  std::string name;
  std::vector<double> x;
  std::vector<double> y;
};

// Inline SVG line chart (no scripts, no external resources).
std::string SvgLineChart(const std::string& title, const std::vector<CurveSeries>& series,
                         int width = 520, int height = 260);

// Reads `*.jsonl` log lines into one series per numeric metric (x = "step").
// Malformed lines are skipped (a log being written while we read may end mid-line).
std::vector<CurveSeries> ReadCurves(const std::string& jsonl_path);

std::string HtmlEscape(const std::string& text);
std::string Base64Encode(const std::string& bytes);

// Builds the page for run_dir and writes it atomically to out_path.
// Throws InputError when run_dir is not a directory.
void WriteRunReport(const std::string& run_dir, const std::string& out_path,
                    const ReportOptions& options);

}  // namespace nerfreg
