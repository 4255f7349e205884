/// @file loop_source.h
/// @brief `replay --loop N`: a recording or synthetic scene played N times, alternately forward
/// and backward, as one continuous stream.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "capture/source.h"

namespace aoscan {

/// The passes `--loop` accepts.
inline constexpr std::int64_t kMinLoopPasses = 1;
inline constexpr std::int64_t kMaxLoopPasses = 100000;

/// Frame spacing (seconds) at a turn when the source cannot tell one (a source of one frame, or
/// all its frames stamped alike): the live rate of the Kinect-class cameras, 30 Hz.
inline constexpr double kLoopFallbackFrameInterval = 1.0 / 30.0;

/// Plays `inner` (n frames, indices 0..n-1) `passes` times as one stream of passes * n frames:
/// even passes forward (0, 1, ..., n-1), odd passes backward (n-1, ..., 1, 0), so the camera path
/// has no jump where one pass meets the next (the turning frame is delivered twice, a camera that
/// stops for one frame). Every frame keeps its depth, calibration, origin and ground truth; what
/// changes:
/// - DepthFrame::sequence is the frame's position in the whole stream (pass * n + i), so it grows
///   monotonically (snapshots and log lines stay unique);
/// - DepthFrame::timestamp_s continues monotonically: with t_first and t_last the timestamps of
///   the first and last frames of the first pass, S = t_last - t_first and d = S / (n - 1) (the
///   mean spacing; kLoopFallbackFrameInterval when S is 0), pass p starts at
///   T_p = t_first + p (S + d), a forward frame of timestamp t is at T_p + (t - t_first) and a
///   backward one at T_p + (t_last - t): pass 0 keeps the recorded timestamps and every pass keeps
///   the recorded spacing (mirrored when backward), so `--realtime` paces each pass like the
///   recording and trajectory.txt stays a valid trajectory.
/// An unreadable frame is reported (corrupt_frame) in every pass it comes in and takes its
/// position. Throws usage_error when `passes` is outside kMinLoopPasses..kMaxLoopPasses, or when
/// `inner` has no random access (not seekable() or no size(): `.oni` files, live cameras).
std::unique_ptr<Source> make_loop_source(std::unique_ptr<Source> inner, std::int64_t passes);

}  // namespace aoscan
