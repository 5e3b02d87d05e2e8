#include "nerfreg/util/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace nerfreg {
namespace {
LogOptions g_options;
}

void InitLogging(const LogOptions& options) {
  g_options = options;
  spdlog::drop("nerfreg");  // re-initialised once the command has parsed --quiet / --json
  auto logger = spdlog::stderr_color_mt("nerfreg");
  if (options.json) {
    logger->set_pattern(R"({"time":"%Y-%m-%dT%H:%M:%S.%e","level":"%l","msg":"%v"})");
  } else {
    logger->set_pattern("[%H:%M:%S %^%l%$] %v");
  }
  logger->set_level(options.quiet ? spdlog::level::warn
                                  : (options.verbose ? spdlog::level::debug : spdlog::level::info));
  spdlog::set_default_logger(logger);
}

const LogOptions& CurrentLogOptions() { return g_options; }

}  // namespace nerfreg
