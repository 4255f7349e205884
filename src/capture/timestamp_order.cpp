/// @file timestamp_order.cpp
/// @brief TimestampOrder: a recording's frames whose timestamps repeat or go back.
#include "capture/timestamp_order.h"

#include <spdlog/spdlog.h>

namespace aoscan {

std::optional<std::string> TimestampOrder::out_of_order(const Source& source,
                                                        const DepthFrame& frame) {
  if (source.live()) return std::nullopt;
  if (last_s_ && !(frame.timestamp_s > *last_s_))
    return source.name() + " (frame " + std::to_string(frame.sequence) + "): timestamp " +
           std::to_string(frame.timestamp_s) + " does not follow " + std::to_string(*last_s_);
  last_s_ = frame.timestamp_s;
  return std::nullopt;
}

void warn_first_out_of_order(const std::string& why) {
  spdlog::warn("{}: frame dropped, as is every frame whose timestamp repeats or goes back", why);
}

}  // namespace aoscan
