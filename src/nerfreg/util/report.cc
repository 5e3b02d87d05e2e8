#include "nerfreg/util/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "nerfreg/util/error.h"

namespace nerfreg {

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
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

namespace {

// About `target` round tick values (1, 2, 5 x 10^k) covering [lo, hi].
std::vector<double> LinearTicks(double lo, double hi, int target = 5) {
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  std::vector<double> ticks;
  for (double t = std::ceil(lo / step) * step; t <= hi + 1e-9 * step; t += step)
    ticks.push_back(std::abs(t) < 1e-12 * step ? 0 : t);
  return ticks;
}

std::string TickLabel(double v) {
  char buf[32];
  if (v != 0 && (std::abs(v) >= 1e5 || std::abs(v) < 1e-3))
    std::snprintf(buf, sizeof buf, "%.0e", v);
  else
    std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

bool PreferLogScale(const std::vector<CurveSeries>& series, double min_ratio) {
  double lo = INFINITY, hi = 0;
  for (const auto& s : series)
    for (double y : s.y) {
      if (!std::isfinite(y)) continue;
      if (y <= 0) return false;
      lo = std::min(lo, y);
      hi = std::max(hi, y);
    }
  return hi > 0 && hi / lo > min_ratio;
}

std::string SvgLineChart(const std::string& title, const std::vector<CurveSeries>& series, const ChartAxes& axes,
                         int width, int height) {
  static const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"};
  auto fy = [&](double y) { return axes.log_y ? std::log10(y) : y; };
  auto usable = [&](double x, double y) { return std::isfinite(x) && std::isfinite(y) && (!axes.log_y || y > 0); };
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;  // y in plotted units
  for (const auto& s : series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!usable(s.x[i], s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, fy(s.y[i]));
      y1 = std::max(y1, fy(s.y[i]));
    }
  if (!std::isfinite(x0)) {
    x0 = 0;
    x1 = 1;
    y0 = 0;
    y1 = 1;
  }
  if (!(x1 > x0)) {
    x0 -= 1;
    x1 += 1;
  }
  if (!(y1 > y0)) {
    y0 -= 0.5;
    y1 += 0.5;
  }
  const double pad = 0.04 * (y1 - y0);
  y0 -= pad;
  y1 += pad;
  const double left = 64, right = 12, top = 26, bottom = 44;
  const double pw = width - left - right, ph = height - top - bottom;
  auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * pw; };
  auto py = [&](double y) { return top + (1 - (y - y0) / (y1 - y0)) * ph; };
  std::ostringstream o;
  o.precision(5);
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height << "\" viewBox=\"0 0 "
    << width << " " << height << "\" role=\"img\" font-family=\"sans-serif\">";
  o << "<text x=\"" << left << "\" y=\"16\" font-size=\"13\" font-weight=\"bold\">" << HtmlEscape(title) << "</text>";
  // Ticks and grid.
  std::vector<std::pair<double, std::string>> yticks;  // plotted value, label
  if (axes.log_y) {
    const int d0 = static_cast<int>(std::floor(y0)), d1 = static_cast<int>(std::ceil(y1));
    const bool few = d1 - d0 <= 2;
    for (int d = d0; d <= d1; ++d)
      for (double m : few ? std::vector<double>{1, 2, 5} : std::vector<double>{1}) {
        const double v = std::log10(m) + d;
        if (v >= y0 && v <= y1) yticks.push_back({v, TickLabel(m * std::pow(10.0, d))});
      }
  } else {
    for (double t : LinearTicks(y0, y1)) yticks.push_back({t, TickLabel(t)});
  }
  for (const auto& [v, label] : yticks) {
    o << "<line x1=\"" << left << "\" x2=\"" << left + pw << "\" y1=\"" << py(v) << "\" y2=\"" << py(v)
      << "\" stroke=\"#e4e4e4\"/><text x=\"" << left - 4 << "\" y=\"" << py(v) + 3
      << "\" font-size=\"10\" text-anchor=\"end\">" << label << "</text>";
  }
  for (double t : LinearTicks(x0, x1, 6)) {
    o << "<line x1=\"" << px(t) << "\" x2=\"" << px(t) << "\" y1=\"" << top + ph << "\" y2=\"" << top + ph + 4
      << "\" stroke=\"#999\"/><text x=\"" << px(t) << "\" y=\"" << top + ph + 15
      << "\" font-size=\"10\" text-anchor=\"middle\">" << TickLabel(t) << "</text>";
  }
  o << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph
    << "\" fill=\"none\" stroke=\"#999\"/>";
  o << "<text x=\"" << left + pw / 2 << "\" y=\"" << height - 6 << "\" font-size=\"11\" text-anchor=\"middle\">"
    << HtmlEscape(axes.x_label) << "</text>";
  const std::string y_label = axes.y_label + (axes.log_y ? " (log scale)" : "");
  o << "<text transform=\"translate(13," << top + ph / 2 << ") rotate(-90)\" font-size=\"11\" text-anchor=\"middle\">"
    << HtmlEscape(y_label) << "</text>";
  for (size_t k = 0; k < series.size(); ++k) {
    const auto& s = series[k];
    std::ostringstream pts;
    pts.precision(6);
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!usable(s.x[i], s.y[i])) continue;
      pts << px(s.x[i]) << "," << py(fy(s.y[i])) << " ";
    }
    const char* colour = kColours[k % 6];
    o << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\" points=\"" << pts.str() << "\"/>";
    if (series.size() > 1) {
      o << "<text x=\"" << left + pw - 6 << "\" y=\"" << top + 14 + 13 * k << "\" font-size=\"11\" fill=\"" << colour
        << "\" text-anchor=\"end\">" << HtmlEscape(s.name) << "</text>";
    }
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

}  // namespace nerfreg
