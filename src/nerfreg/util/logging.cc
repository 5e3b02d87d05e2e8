#include "nerfreg/util/logging.h"

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include <nlohmann/json.hpp>

namespace nerfreg {
namespace {
LogOptions g_options;

// The message as the inside of a JSON string: messages carry paths and quoted names, which the
// plain %v flag would copy into the line unescaped (broken JSON). Invalid UTF-8 becomes U+FFFD.
class JsonEscapedMessage : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&, spdlog::memory_buf_t& dest) override {
    const std::string quoted = nlohmann::json(std::string(msg.payload.data(), msg.payload.size()))
                                   .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    dest.append(quoted.data() + 1, quoted.data() + quoted.size() - 1);
  }
  std::unique_ptr<custom_flag_formatter> clone() const override { return std::make_unique<JsonEscapedMessage>(); }
};
}  // namespace

void InitLogging(const LogOptions& options) {
  g_options = options;
  spdlog::drop("nerfreg");  // re-initialised once the command has parsed --quiet / --json
  auto logger = spdlog::stderr_color_mt("nerfreg");
  if (options.json) {
    auto formatter = std::make_unique<spdlog::pattern_formatter>();
    formatter->add_flag<JsonEscapedMessage>('*').set_pattern(
        R"({"time":"%Y-%m-%dT%H:%M:%S.%e","level":"%l","msg":"%*"})");
    logger->set_formatter(std::move(formatter));
  } else {
    logger->set_pattern("[%H:%M:%S %^%l%$] %v");
  }
  logger->set_level(options.quiet ? spdlog::level::warn
                                  : (options.verbose ? spdlog::level::debug : spdlog::level::info));
  spdlog::set_default_logger(logger);
}

const LogOptions& CurrentLogOptions() { return g_options; }

}  // namespace nerfreg
