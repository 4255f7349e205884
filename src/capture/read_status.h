/// @file read_status.h
/// @brief The one handling of Source::read's status, shared by every loop that reads a source (or
/// steps a frame through a stage): use the frame, skip a corrupt one, or stop.
#pragma once

#include "core/log.h"
#include "core/status.h"

namespace aoscan {

/// What a loop does after a read (or a stage step).
enum class ReadStep {
  kFrame,  ///< ok: use the frame
  kSkip,   ///< a corrupt frame, counted: go on with the next one
  kStop,   ///< the stream ended, or cannot go on (then `stopped_by` says why): leave the loop
};

/// How a loop treats corrupt frames.
struct ReadPolicy {
  /// A corrupt frame ends the stream as bad input (exit 3) instead of being a counted skip.
  bool strict = false;
  /// Logged as a warning in front of a skipped frame's message; nullptr: skips are not logged.
  const char* skip_warning = nullptr;
};

/// Handles `status`: ok gives kFrame; a corrupt frame is counted in `corrupt` and gives kSkip
/// (strict: kStop with `stopped_by` = bad_input); end of stream gives kStop and leaves
/// `stopped_by` alone; any other status gives kStop with `stopped_by` = status. `Counter` is an
/// integer or an atomic one.
template <typename Counter>
ReadStep handle_read_status(const Status& status, const ReadPolicy& policy, Counter& corrupt,
                            Status& stopped_by) {
  switch (status.code()) {
    case Status::Code::kOk:
      return ReadStep::kFrame;
    case Status::Code::kEndOfStream:
      return ReadStep::kStop;
    case Status::Code::kCorruptFrame:
      ++corrupt;
      if (policy.strict) {
        stopped_by = Status::bad_input(status.message());
        return ReadStep::kStop;
      }
      if (policy.skip_warning) spdlog::warn("{}{}", policy.skip_warning, status.message());
      return ReadStep::kSkip;
    default:
      stopped_by = status;
      return ReadStep::kStop;
  }
}

}  // namespace aoscan
