#include "core/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "core/error.h"

namespace dome::core {

void SetUpLogging(const std::string& level, const std::string& flag) {
  const spdlog::level::level_enum parsed = spdlog::level::from_str(level);
  // from_str maps unknown names to "off"; only accept "off" when asked for.
  Require(parsed != spdlog::level::off || level == "off", flag,
          "unknown log level '" + level + "' (expected trace, debug, info, warn, error or off)");
  auto logger = spdlog::stderr_color_mt("dome");
  logger->set_pattern("%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(parsed);
}

}  // namespace dome::core
