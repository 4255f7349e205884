/// @file log.cpp
/// @brief Logging set-up.
#include "core/log.h"

#include <spdlog/sinks/stdout_sinks.h>

#include "core/status.h"

namespace aoscan {

void configure_logging(const std::string& level) {
  const auto parsed = spdlog::level::from_str(level);
  if (parsed == spdlog::level::off && level != "off")
    throw usage_error("--log-level " + level + ": expected trace, debug, info, warn, error or off");
  auto logger = spdlog::stderr_logger_mt("aoscan");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("aoscan: %l: %v");
  spdlog::set_level(parsed);
}

}  // namespace aoscan
