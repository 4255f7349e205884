/// @file source.h
/// @brief The one interface every depth source implements: recordings, synthetic scenes, cameras.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "core/depth_frame.h"
#include "core/mesh.h"
#include "core/status.h"

namespace aoscan {

/// A stream of depth frames. Not thread-safe: one thread reads it (the capture stage).
class Source {
 public:
  virtual ~Source() = default;

  /// Fills `frame` with the next frame and returns ok; or returns end_of_stream; or
  /// corrupt_frame (this frame is skipped, the stream goes on; the message names the file and
  /// frame); or bad_input / device_lost when the stream cannot go on. Never throws.
  /// `frame`'s buffers are reused, so a caller can read into the same object every time.
  virtual Status read(DepthFrame& frame) = 0;

  /// A short human-readable name (folder, URI, synth spec) for messages.
  virtual std::string name() const = 0;
  /// Nominal calibration of the stream (each frame carries its own copy too).
  virtual const Intrinsics& intrinsics() const = 0;
  /// Raw units per metre of the frames.
  virtual double depth_scale() const = 0;
  /// Where intrinsics() and depth_scale() come from (a file, a driver, a default), for the log
  /// and stats.json.
  virtual std::string calibration_origin() const { return "the source"; }
  /// True when the calibration is a generic default, not this camera's: the run warns.
  virtual bool calibration_is_default() const { return false; }
  /// Where the colour camera's calibration comes from (a file, a driver, "assumed registered");
  /// "" when the source has no colour.
  virtual std::string colour_origin() const { return ""; }
  /// Number of frames when known in advance (recordings, synthetic scenes).
  virtual std::optional<std::size_t> size() const { return std::nullopt; }
  /// True for live cameras: they never wait for the consumer.
  virtual bool live() const { return false; }
  /// True when seek() works: sources with random access by frame index (recordings, synthetic
  /// scenes).
  virtual bool seekable() const { return false; }
  /// Makes frame `index` (0-based, below size()) the one the next read() delivers. Returns
  /// internal for a source that is not seekable() or an index past its end.
  virtual Status seek(std::size_t index) {
    return Status::internal(name() + ": cannot seek to frame " + std::to_string(index));
  }
  /// Exact scene geometry in the world frame of the ground-truth poses, when the source knows it.
  virtual const TriangleMesh* scene_mesh() const { return nullptr; }

  /// A flag whose setting ends the stream (may be null): a read waiting for a camera's next
  /// frame returns end of stream within kStopPollInterval of it instead of waiting out its
  /// timeout. Set by the reading loop before its first read; the flag must outlive the reads.
  void watch_stop(const std::atomic<bool>* stop) { stop_ = stop; }
  /// With false, a source that has colour delivers none (nothing is decoded); with `every` > 1
  /// (fusion.colour_every) a recording decodes only the colour of the frames colour_frame()
  /// names; set before the first read.
  void want_colour(bool wanted, int every = 1) {
    colour_wanted_ = wanted;
    colour_every_ = every;
  }

 protected:
  bool stop_requested() const { return stop_ != nullptr && stop_->load(); }
  bool colour_wanted() const { return colour_wanted_; }
  /// Colour wanted, and frame `sequence` is one whose colour is fused.
  bool colour_wanted(std::uint64_t sequence) const {
    return colour_wanted_ && colour_frame(sequence, colour_every_);
  }
  /// For a source that wraps another: hands the stop flag and the colour choice on to `inner`.
  void forward_settings(Source& inner) const {
    inner.watch_stop(stop_);
    inner.want_colour(colour_wanted_, colour_every_);
  }

 private:
  const std::atomic<bool>* stop_ = nullptr;
  bool colour_wanted_ = true;
  int colour_every_ = 1;
};

/// How often every wait of the program (replay pacing, a camera's frame wait) looks at the stop
/// flag: a stop request is seen within this time.
inline constexpr std::chrono::milliseconds kStopPollInterval{50};

/// Raw units per metre of the live cameras that deliver millimetres (libfreenect in mm mode, V4L2
/// Z16).
inline constexpr double kMillimetreDepthScale = 1000.0;

/// What every live camera delivering millimetres shares: its name and calibration, depth_scale
/// kMillimetreDepthScale, live() true, and how its frames are stamped.
class LiveMillimetreSource : public Source {
 public:
  std::string name() const override { return name_; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return kMillimetreDepthScale; }
  std::string calibration_origin() const override { return "the camera's driver"; }
  bool live() const override { return true; }

 protected:
  explicit LiveMillimetreSource(std::string name) : name_(std::move(name)) {}

  /// Stamps a frame: depth_scale, the camera's intrinsics, the driver's timestamp and sequence
  /// number, origin = the camera's name, no ground truth. The depth (and arrived_at) are the
  /// caller's.
  void stamp(DepthFrame& frame, double timestamp_s, std::uint64_t sequence) const {
    frame.depth_scale = kMillimetreDepthScale;
    frame.intrinsics = intrinsics_;
    frame.timestamp_s = timestamp_s;
    frame.sequence = sequence;
    frame.origin = name_;
    frame.T_world_camera_gt.reset();
  }

  std::string name_;
  Intrinsics intrinsics_;
};

/// Opens SOURCE as the contract spells it: a TUM-layout folder, `synth:NAME?k=v&...`,
/// `FILE.oni` and live camera URIs. Throws Error: usage_error for an unknown synth scene or
/// parameter, input_error for a missing or broken recording (also `.oni`), device_error for
/// cameras (`openni2[:URI]`, `freenect[:INDEX]`, `v4l2:/dev/videoN`, `auto`).
std::unique_ptr<Source> open_source(const std::string& spec);

/// True when `spec` names a live camera (`openni2[:URI]`, `freenect[:INDEX]`, `v4l2:...`,
/// `auto`), whether or not it is plugged in.
bool is_camera_spec(const std::string& spec);

}  // namespace aoscan
