#pragma once
// One levelled logger for the whole program (spdlog), writing to stderr so stdout stays free for
// results. --quiet raises the level to warnings; --json switches every log line and progress
// update to one JSON object per line for machines.
#include <spdlog/spdlog.h>

#include <string>

namespace nerfreg {

struct LogOptions {
  bool quiet = false;    // warnings and errors only; no progress bars
  bool json = false;     // JSON lines on stderr instead of human text
  bool verbose = false;  // debug messages
};

void InitLogging(const LogOptions& options);
const LogOptions& CurrentLogOptions();

}  // namespace nerfreg

#define LOG_DEBUG(...) SPDLOG_DEBUG(__VA_ARGS__)
#define LOG_INFO(...) spdlog::info(__VA_ARGS__)
#define LOG_WARN(...) spdlog::warn(__VA_ARGS__)
#define LOG_ERROR(...) spdlog::error(__VA_ARGS__)
