/// @file log.h
/// @brief The one logging sink of aoscan: spdlog to stderr, quiet (warnings) by default.
#pragma once

#include <string>

#include <spdlog/spdlog.h>

namespace aoscan {

/// Routes all logging to stderr at `level` (trace, debug, info, warn, error, off); throws
/// usage_error on an unknown level.
void configure_logging(const std::string& level);

}  // namespace aoscan
