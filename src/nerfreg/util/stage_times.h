#pragma once
// Wall times of a pipeline's named stages, in the order they first ran (a stage recorded twice
// adds up): what `dbarf poses` logs one line per stage for and writes as "timings_s".
#include <string>
#include <utility>
#include <vector>

#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

class StageTimes {
 public:
  // Adds `seconds` to `stage` and logs one info line for it.
  void Record(const std::string& stage, double seconds) {
    Add(stage, seconds);
    LOG_INFO("stage {}: {:.2f} s", stage, seconds);
  }
  // Adds without logging (e.g. a stage whose parts were logged already).
  void Add(const std::string& stage, double seconds) {
    for (auto& [name, s] : stages_)
      if (name == stage) {
        s += seconds;
        return;
      }
    stages_.emplace_back(stage, seconds);
  }
  void Append(const StageTimes& other) {
    for (const auto& [name, s] : other.stages_) Add(name, s);
  }
  double Seconds(const std::string& stage) const {
    for (const auto& [name, s] : stages_)
      if (name == stage) return s;
    return 0;
  }
  const std::vector<std::pair<std::string, double>>& stages() const { return stages_; }
  // {"stage": seconds, ...} (a JSON object: keys sorted by name).
  Json ToJson() const {
    Json out = Json::object();
    for (const auto& [name, s] : stages_) out[name] = s;
    return out;
  }
  // "features 1.20, matching 3.40, ..." (seconds) for a summary line.
  std::string Summary() const {
    std::string out;
    for (const auto& [name, s] : stages_) out += (out.empty() ? "" : ", ") + name + " " + fmt::format("{:.2f}", s);
    return out;
  }

 private:
  std::vector<std::pair<std::string, double>> stages_;
};

}  // namespace nerfreg
