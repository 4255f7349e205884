/// @file fakenect_dump.h
/// @brief Writes any Source as a fakenect dump, so libfreenect's fakenect library can replay it
/// as if a Kinect v1 were plugged in (FAKENECT_PATH=DIR, fakenect's libfreenect.so loaded).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "capture/source.h"

namespace aoscan {

/// Width and height of the only depth mode fakenect replays.
constexpr int kFakenectWidth = 640;
constexpr int kFakenectHeight = 480;
/// Tick rate of the Kinect v1 frame timestamps (60 MHz, 32-bit, wrapping).
constexpr double kKinectClockHz = 60e6;

struct FakenectDumpStats {
  std::size_t frames_written = 0;
  std::size_t frames_corrupt = 0;       ///< corrupt source frames skipped
  std::size_t pixels_out_of_range = 0;  ///< valid depths the Kinect cannot report (written invalid)
  std::size_t colour_frames_written = 0;  ///< `r-*.ppm` video frames
  std::size_t colour_frames_skipped = 0;  ///< colour frames not 640x480 (not written)
};

/// Name of dump file `index`-th depth frame in fakenect's scheme `d-<time s>-<ticks>.pgm`, where
/// time is the capture time in seconds (fakenect sleeps by its differences) and ticks the device
/// timestamp handed to the depth callback.
std::string fakenect_depth_file_name(double time_s, std::uint32_t ticks);

/// Name of a video frame in the same scheme: `r-<time s>-<ticks>.ppm`.
std::string fakenect_video_file_name(double time_s, std::uint32_t ticks);

/// Reads `source` until it ends, `max_frames` are written or `*stop_requested` (may be null), and
/// writes into `dir` (created): one `d-*.pgm` per frame (a `P5 640 480 65535` header line, then
/// 640x480 little-endian 11-bit disparities, 2047 = invalid, from kinect_mm_to_raw) and INDEX.txt
/// listing them in order (flushed after each frame, so the dump is valid at any moment). Frame
/// times are the source's timestamps (s); ticks are (t - t_first) * 60 MHz modulo 2^32, t_first
/// the first depth frame's time. A frame with a 640x480 colour image also gets an `r-*.ppm` video
/// frame (a `P6 640 480 255` header line, then the RGB bytes) at its colour timestamp, listed
/// before or after the depth frame as the two times fall (fakenect replays INDEX.txt in order);
/// colour of another size is counted in colour_frames_skipped.
/// Throws usage_error when `dir` already holds an INDEX.txt, input_error when a frame is not
/// 640x480 (the message names the frame) or the source fails, device_error for a lost device,
/// Error (exit 1) when a file cannot be written.
FakenectDumpStats write_fakenect_dump(Source& source, const std::string& dir,
                                      std::optional<std::size_t> max_frames,
                                      const std::atomic<bool>* stop_requested);

}  // namespace aoscan
