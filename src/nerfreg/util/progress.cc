#include "nerfreg/util/progress.h"

#include <cmath>
#include <cstdio>
#include <unistd.h>

#include "nerfreg/util/logging.h"

namespace nerfreg {

std::string FormatDuration(double s) {
  char buf[32];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60) {
    std::snprintf(buf, sizeof(buf), "%.1fs", s);
  } else if (s < 3600) {
    std::snprintf(buf, sizeof(buf), "%dm%02ds", int(s) / 60, int(s) % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%dh%02dm", int(s) / 3600, (int(s) % 3600) / 60);
  }
  return buf;
}

ProgressBar::ProgressBar(std::string label, std::int64_t total, std::string unit)
    : label_(std::move(label)), total_(total), unit_(std::move(unit)) {
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

ProgressBar::~ProgressBar() {
  if (!finished_) Finish();
}

double ProgressBar::ElapsedSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressBar::Tick(std::int64_t n) {
  done_ += n;
  const auto now = std::chrono::steady_clock::now();
  // Terminals get ~5 redraws a second; logs and JSON consumers one line every 5 seconds.
  const double interval = isatty(STDERR_FILENO) && !CurrentLogOptions().json ? 0.2 : 5.0;
  if (std::chrono::duration<double>(now - last_draw_).count() >= interval) {
    last_draw_ = now;
    Draw(false);
  }
}

void ProgressBar::SetMetric(const std::string& name, double value) { metrics_[name] = value; }

void ProgressBar::Finish() {
  if (finished_) return;
  finished_ = true;
  Draw(true);
}

void ProgressBar::Resume(std::int64_t done) {
  done_ += done;
  resumed_ += done;
}

double ProgressBar::Rate() const {
  const double elapsed = ElapsedSeconds();
  return elapsed > 0 ? (done_ - resumed_) / elapsed : 0.0;
}

double ProgressBar::EtaSeconds() const {
  const double rate = Rate();
  return rate > 0 && total_ > 0 ? (total_ - done_) / rate : NAN;
}

void ProgressBar::Draw(bool final) {
  const LogOptions& opt = CurrentLogOptions();
  if (opt.quiet) return;
  const double elapsed = ElapsedSeconds();
  const double rate = Rate();
  const double eta = EtaSeconds();
  if (opt.json) {
    std::string line = "{\"progress\":\"" + label_ + "\",\"done\":" + std::to_string(done_) +
                       ",\"total\":" + std::to_string(total_) + ",\"rate\":" + std::to_string(rate) +
                       ",\"elapsed_s\":" + std::to_string(elapsed);
    if (std::isfinite(eta)) line += ",\"eta_s\":" + std::to_string(eta);
    // A diverged loss is NaN, which JSON cannot write: null.
    for (const auto& [k, v] : metrics_) line += ",\"" + k + "\":" + (std::isfinite(v) ? std::to_string(v) : "null");
    std::fprintf(stderr, "%s}\n", line.c_str());
    return;
  }
  const int width = 24;
  const double frac = total_ > 0 ? std::min(1.0, double(done_) / total_) : 0.0;
  const int filled = static_cast<int>(frac * width);
  std::string bar(filled, '#');
  bar += std::string(width - filled, '.');
  std::string metrics;
  char buf[64];
  for (const auto& [k, v] : metrics_) {
    std::snprintf(buf, sizeof(buf), " %s=%.4g", k.c_str(), v);
    metrics += buf;
  }
  const bool tty = isatty(STDERR_FILENO);
  std::fprintf(stderr, "%s%s [%s] %lld/%lld %.2f %s/s elapsed %s ETA %s%s%s", tty ? "\r\033[K" : "", label_.c_str(),
               bar.c_str(), static_cast<long long>(done_), static_cast<long long>(total_), rate, unit_.c_str(),
               FormatDuration(elapsed).c_str(), final ? "0s" : FormatDuration(eta).c_str(), metrics.c_str(),
               (final || !tty) ? "\n" : "");
  std::fflush(stderr);
}

}  // namespace nerfreg
