/// @file timestamp_order.h
/// @brief The check that a recording's timestamps increase, shared by every loop that reads a
/// recording in order (the pipeline's capture stage, the recorder).
#pragma once

#include <optional>
#include <string>

#include "capture/source.h"

namespace aoscan {

/// Keeps a recording's timestamps increasing: trajectory.txt is keyed by them, and pacing by them
/// would stall. Camera clocks may wrap, so live sources are not checked.
class TimestampOrder {
 public:
  /// Why `frame` (just read from `source`) repeats or goes back in time, naming the source and
  /// frame; nullopt when it follows the last frame that did, and then it becomes that frame.
  std::optional<std::string> out_of_order(const Source& source, const DepthFrame& frame);

 private:
  std::optional<double> last_s_;
};

/// The warning for the first frame a loop drops because out_of_order() gave `why` (later ones
/// are only counted).
void warn_first_out_of_order(const std::string& why);

}  // namespace aoscan
