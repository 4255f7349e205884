/// @file colour_stream.h
/// @brief What the live cameras share about their colour stream: decoding its frames (RGB24,
/// YUYV, MJPEG) and pairing each depth frame with the colour frame nearest to it in time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/colour.h"
#include "core/depth_frame.h"
#include "core/image.h"
#include "core/status.h"
#include "io/tum.h"

namespace aoscan {

/// Pixel formats of a camera's colour frames that aoscan decodes.
enum class ColourPixelFormat {
  kRgb24,  ///< 3 bytes a pixel, R G B (OpenNI2's RGB888, libfreenect's RGB, V4L2's RGB3)
  kYuyv,   ///< 4:2:2, Y0 U Y1 V for two pixels, BT.601 limited range (V4L2's YUYV)
  kMjpeg,  ///< one JPEG image a frame (V4L2's MJPG), decoded with the colour image codecs
};

/// Decodes one colour frame: `height` rows of `width` pixels, each row `bytes_per_line` bytes
/// after the previous (ignored for MJPEG, whose image carries its own size); `bytes_used` is what
/// the driver filled. Resizes `out` (no allocation when the size is unchanged). Returns
/// corrupt_frame naming `origin` for a short buffer, an impossible geometry or a JPEG that does
/// not decode; never throws.
Status decode_colour_frame(ColourPixelFormat format, const std::uint8_t* data,
                           std::size_t bytes_used, int width, int height, int bytes_per_line,
                           Image<Rgb8>& out, const std::string& origin);

/// The colour camera of a depth camera whose depth the device has resampled onto the colour
/// camera's pixels (hardware registration), for colour frames of `width` x `height`: registered
/// when that is the depth size, else the same view at the colour frames' resolution (identity
/// pose, intrinsics scaled from the depth's).
ColourCamera registered_colour_camera(const Intrinsics& depth, int width, int height);

/// A live camera's colour frames waiting to be paired with depth frames: the last few colour
/// frames with their device timestamps (seconds, the depth frames' clock). Each depth frame takes
/// the unused colour frame nearest to it in time within `max_dt_s` (the TUM reader's
/// kColourMaxDtS, 20 ms, by default); a colour frame is used at most once. Storage is recycled: no
/// allocation once the buffers have their size. Not thread-safe (the reading thread owns it).
class ColourPairer {
 public:
  explicit ColourPairer(std::size_t capacity = 4, double max_dt_s = kColourMaxDtS);

  /// Where to decode the next colour frame (the oldest buffer is reused).
  Image<Rgb8>& next_buffer();
  /// The frame decoded into next_buffer() is stamped `timestamp_s`.
  void commit(double timestamp_s);
  /// A colour frame arrived at `timestamp_s` but could not be used (undecodable, broken): a
  /// depth frame that would have paired with it gets `why` as its colour error.
  void commit_failed(double timestamp_s, std::string why);

  /// True when waiting for the next colour frame may give `depth_timestamp_s` a nearer partner:
  /// no buffered colour frame is at or after it, and the colour stream is flowing: its newest
  /// frame is less than `stall_s` older than the depth frame (a stream that has stopped is not
  /// waited for) or, before any colour frame arrived, the first depth frame asked about is less
  /// than `stall_s` older (a stream that is starting is waited for, one that never delivers only
  /// that long).
  bool worth_waiting(double depth_timestamp_s, double stall_s = kDefaultStallS);

  /// Gives `frame` (timestamp_s set) its colour: the camera, and the nearest unused colour frame
  /// within max_dt_s swapped into frame.colour with frame.colour_timestamp_s; or an empty colour
  /// and frame.colour_error naming `where` (no colour frame near it, its colour frame failed, or
  /// its size is not `camera`'s).
  void pair(DepthFrame& frame, const ColourCamera& camera, const std::string& where);

  std::size_t frames_received() const { return received_; }

  static constexpr double kDefaultStallS = 0.2;   ///< six frames at 30 Hz

 private:
  struct Slot {
    Image<Rgb8> image;
    double timestamp_s = 0.0;
    std::string error;  ///< non-empty: the frame failed
    bool filled = false;
    bool used = false;
  };
  std::vector<Slot> slots_;
  std::size_t next_ = 0;  ///< the slot next_buffer() hands out
  double max_dt_s_;
  std::size_t received_ = 0;
  bool have_newest_ = false;
  double newest_s_ = 0.0;
  bool have_first_depth_ = false;
  double first_depth_s_ = 0.0;
};

}  // namespace aoscan
