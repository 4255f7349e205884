/// @file depth_frame.h
/// @brief One depth frame as it leaves a Source: raw 16-bit depth plus everything needed to use it.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "core/colour.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"

namespace aoscan {

/// Raw depth as the sensor or file gave it. A raw value of 0 is invalid; metres = raw / depth_scale.
struct DepthFrame {
  Image<std::uint16_t> depth;      ///< raw units, 0 = invalid
  double depth_scale = 1000.0;     ///< raw units per metre
  Intrinsics intrinsics;           ///< calibration of this frame (travels with it)
  double timestamp_s = 0.0;        ///< the source's own timestamp, seconds
  std::uint64_t sequence = 0;      ///< index of the frame in its source (skipped frames count)
  std::string origin;              ///< where it came from (file path or device), for messages
  std::optional<Pose> T_world_camera_gt;  ///< ground truth when the source knows it
  /// The colour image taken with this depth frame (its own size; empty when the source has no
  /// colour or this frame's colour was skipped) and the colour camera's calibration (set whenever
  /// the source has colour).
  Image<Rgb8> colour;
  std::optional<ColourCamera> colour_camera;
  double colour_timestamp_s = 0.0;  ///< the colour image's own timestamp (seconds)
  /// Why this frame has no colour although its source has colour ("" otherwise): a missing or
  /// corrupt colour file, a colour image of the wrong size, no colour frame near its timestamp.
  /// The depth is used all the same; the run counts and reports these.
  std::string colour_error;
  /// This frame has no colour and its source none: every colour member emptied.
  void clear_colour() {
    colour.resize(0, 0);
    colour_camera.reset();
    colour_error.clear();
    colour_timestamp_s = 0.0;
  }
  /// Host steady-clock time at which the frame reached this process: set by live sources (the
  /// driver's frame callback or buffer wake-up); recordings leave it empty and the pipeline stamps
  /// the moment the frame is delivered. Where the capture latency starts.
  std::chrono::steady_clock::time_point arrived_at{};
};

}  // namespace aoscan
