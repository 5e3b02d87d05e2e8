#include "nerfreg/util/report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace fs = std::filesystem;

namespace nerfreg {

void ReportOptions::Check() const {
  if (max_images < 0 || max_image_bytes < 0) throw std::invalid_argument("ReportOptions: negative limit");
}

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Base64Encode(const std::string& in) {
  static const char* kTable = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (unsigned char)in[i] << 16 | (unsigned char)in[i + 1] << 8 | (unsigned char)in[i + 2];
    out += kTable[v >> 18];
    out += kTable[(v >> 12) & 63];
    out += kTable[(v >> 6) & 63];
    out += kTable[v & 63];
  }
  if (i < in.size()) {
    unsigned v = (unsigned char)in[i] << 16;
    if (i + 1 < in.size()) v |= (unsigned char)in[i + 1] << 8;
    out += kTable[v >> 18];
    out += kTable[(v >> 12) & 63];
    out += i + 1 < in.size() ? kTable[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string SvgLineChart(const std::string& title, const std::vector<CurveSeries>& series, int width,
                         int height) {
  static const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"};
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const auto& s : series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  if (!(x1 > x0)) { x0 -= 1; x1 += 1; }
  if (!(y1 > y0)) { y0 -= 1; y1 += 1; }
  const double left = 60, right = 10, top = 24, bottom = 30;
  const double pw = width - left - right, ph = height - top - bottom;
  auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * pw; };
  auto py = [&](double y) { return top + (1 - (y - y0) / (y1 - y0)) * ph; };
  std::ostringstream o;
  o.precision(4);
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
    << "\" viewBox=\"0 0 " << width << " " << height << "\" role=\"img\">";
  o << "<text x=\"" << left << "\" y=\"16\" font-size=\"13\" font-family=\"sans-serif\">"
    << HtmlEscape(title) << "</text>";
  o << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph
    << "\" fill=\"none\" stroke=\"#999\"/>";
  o << "<text x=\"4\" y=\"" << top + 10 << "\" font-size=\"10\" font-family=\"sans-serif\">" << y1 << "</text>";
  o << "<text x=\"4\" y=\"" << top + ph << "\" font-size=\"10\" font-family=\"sans-serif\">" << y0 << "</text>";
  o << "<text x=\"" << left << "\" y=\"" << height - 8 << "\" font-size=\"10\" font-family=\"sans-serif\">" << x0
    << "</text>";
  o << "<text x=\"" << left + pw - 40 << "\" y=\"" << height - 8
    << "\" font-size=\"10\" font-family=\"sans-serif\">" << x1 << "</text>";
  for (size_t k = 0; k < series.size(); ++k) {
    const auto& s = series[k];
    std::ostringstream pts;
    pts.precision(6);
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      pts << px(s.x[i]) << "," << py(s.y[i]) << " ";
    }
    const char* colour = kColours[k % 6];
    o << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\" points=\"" << pts.str()
      << "\"/>";
    o << "<text x=\"" << left + pw - 120 << "\" y=\"" << top + 14 + 13 * k << "\" font-size=\"11\" fill=\""
      << colour << "\" font-family=\"sans-serif\">" << HtmlEscape(s.name) << "</text>";
  }
  o << "</svg>";
  return o.str();
}

std::vector<CurveSeries> ReadCurves(const std::string& jsonl_path) {
  std::ifstream in(jsonl_path);
  std::map<std::string, CurveSeries> by_name;
  std::string line;
  while (std::getline(in, line)) {
    Json j;
    try {
      j = ParseJson(line, jsonl_path);
    } catch (const InputError&) {
      continue;
    }
    if (!j.is_object() || !j.contains("step") || !j["step"].is_number()) continue;
    const double step = j["step"].get<double>();
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.key() == "step" || !it.value().is_number()) continue;
      CurveSeries& s = by_name[it.key()];
      s.name = it.key();
      s.x.push_back(step);
      s.y.push_back(it.value().get<double>());
    }
  }
  std::vector<CurveSeries> out;
  for (auto& [name, s] : by_name) out.push_back(std::move(s));
  return out;
}

namespace {

std::string JsonTable(const Json& j) {
  std::ostringstream o;
  o << "<table>";
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string v = it.value().is_string() ? it.value().get<std::string>() : it.value().dump();
      o << "<tr><th>" << HtmlEscape(it.key()) << "</th><td>"
        << HtmlEscape(v.size() > 400 ? v.substr(0, 400) + " ..." : v) << "</td></tr>";
    }
  } else {
    const std::string v = j.dump();
    o << "<tr><td>" << HtmlEscape(v.size() > 2000 ? v.substr(0, 2000) + " ..." : v) << "</td></tr>";
  }
  o << "</table>";
  return o.str();
}

}  // namespace

void WriteRunReport(const std::string& run_dir, const std::string& out_path, const ReportOptions& options) {
  options.Check();
  if (!DirExists(run_dir)) ThrowInputError(run_dir, "", "a run directory");
  std::vector<fs::path> pngs, jsons, logs, datasets;
  for (auto it = fs::recursive_directory_iterator(run_dir); it != fs::recursive_directory_iterator(); ++it) {
    // Input datasets inside the run (a folder with a transforms.json) are listed, not shown: the
    // page is about the run's results.
    if (it->is_directory() && fs::exists(it->path() / "transforms.json")) {
      datasets.push_back(it->path());
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file()) continue;
    const fs::path& p = it->path();
    if (p.filename().string().rfind('.', 0) == 0) continue;  // temp files
    const std::string ext = LowerExtension(p.string());
    if (ext == ".png") pngs.push_back(p);
    else if (ext == ".json") jsons.push_back(p);
    else if (ext == ".jsonl") logs.push_back(p);
  }
  // Results first: files at the top of the run before those in sub-folders, then by name.
  auto by_depth = [](const fs::path& a, const fs::path& b) {
    const auto da = std::distance(a.begin(), a.end()), db = std::distance(b.begin(), b.end());
    return da != db ? da < db : a < b;
  };
  std::sort(pngs.begin(), pngs.end(), by_depth);
  std::sort(jsons.begin(), jsons.end(), by_depth);
  std::sort(datasets.begin(), datasets.end());
  std::sort(logs.begin(), logs.end());
  const std::string title = options.title.empty() ? fs::path(run_dir).filename().string() : options.title;

  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << HtmlEscape(title) << "</title><style>"
    << "body{font-family:sans-serif;margin:1.5em;color:#222}h2{border-bottom:1px solid #ccc}"
    << "table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ddd;padding:2px 8px;"
    << "text-align:left;font-size:13px}figure{display:inline-block;margin:4px;text-align:center}"
    << "figcaption{font-size:11px}img{image-rendering:pixelated;max-width:320px}</style></head><body>";
  h << "<h1>" << HtmlEscape(title) << "</h1><p>Run directory: <code>" << HtmlEscape(run_dir) << "</code></p>";

  if (!datasets.empty()) {
    h << "<p>Datasets in this run (not shown):";
    for (const auto& d : datasets) h << " <code>" << HtmlEscape(fs::relative(d, run_dir).string()) << "</code>";
    h << "</p>";
  }
  h << "<h2>Metrics and options</h2>";
  if (jsons.empty()) h << "<p>No JSON files.</p>";
  for (const auto& p : jsons) {
    const std::string rel = fs::relative(p, run_dir).string();
    h << "<h3>" << HtmlEscape(rel) << "</h3>";
    try {
      const Json j = ParseJson(ReadFileToString(p.string(), 4 << 20), p.string());
      h << JsonTable(j);
    } catch (const std::exception& e) {
      h << "<p>unreadable: " << HtmlEscape(e.what()) << "</p>";
    }
  }

  h << "<h2>Training curves</h2>";
  if (logs.empty()) h << "<p>No training logs.</p>";
  for (const auto& p : logs) {
    const auto curves = ReadCurves(p.string());
    for (const auto& c : curves) {
      if (c.x.size() < 2) continue;  // a single point is not a curve
      h << SvgLineChart(fs::relative(p, run_dir).string() + ": " + c.name, {c});
    }
  }

  h << "<h2>Images</h2>";
  if (pngs.empty()) h << "<p>No images.</p>";
  std::string current_dir = "\x01";
  int embedded = 0;
  for (const auto& p : pngs) {
    const std::string rel = fs::relative(p, run_dir).string();
    const std::string dir = fs::path(rel).parent_path().string();
    if (dir != current_dir) {
      current_dir = dir;
      h << "<h3>" << HtmlEscape(dir.empty() ? "." : dir) << "</h3>";
    }
    const auto size = static_cast<long long>(fs::file_size(p));
    if (embedded >= options.max_images || size > options.max_image_bytes) {
      h << "<p>" << HtmlEscape(rel) << " (not embedded)</p>";
      continue;
    }
    ++embedded;
    h << "<figure><img alt=\"" << HtmlEscape(rel) << "\" src=\"data:image/png;base64,"
      << Base64Encode(ReadFileToString(p.string())) << "\"><figcaption>" << HtmlEscape(fs::path(rel).filename().string())
      << "</figcaption></figure>";
  }
  h << "</body></html>\n";
  WriteFileAtomic(out_path, h.str());
}

}  // namespace nerfreg
