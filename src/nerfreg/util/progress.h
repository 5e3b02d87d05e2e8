#pragma once
// Progress for long work: a bar with count, rate, ETA and free-form metrics (loss, PSNR) on
// stderr, redrawn at most a few times a second. Silent with --quiet; with --json each update is
// a JSON line {"progress": label, "done": n, "total": N, "rate": r, "eta_s": e, ...metrics}.
#include <chrono>
#include <cstdint>
#include <map>
#include <string>

namespace nerfreg {

class ProgressBar {
 public:
  ProgressBar(std::string label, std::int64_t total, std::string unit = "it");
  ~ProgressBar();

  // Advances by n and redraws if enough time passed.
  void Tick(std::int64_t n = 1);
  // A resumed run: `done` units were done by an earlier run. They fill the bar but not the rate,
  // so the rate and ETA are this run's.
  void Resume(std::int64_t done);
  double Rate() const;        // units per second in this run
  double EtaSeconds() const;  // NaN while the rate is unknown
  // Sets a metric shown after the bar (kept until changed).
  void SetMetric(const std::string& name, double value);
  // Final redraw and newline.
  void Finish();

  double ElapsedSeconds() const;
  std::int64_t done() const { return done_; }

 private:
  void Draw(bool final);

  std::string label_;
  std::int64_t total_;
  std::string unit_;
  std::int64_t done_ = 0;
  std::int64_t resumed_ = 0;  // of done_, what an earlier run did
  std::map<std::string, double> metrics_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  bool finished_ = false;
};

// "1h02m", "3m05s", "12.3s".
std::string FormatDuration(double seconds);

}  // namespace nerfreg
