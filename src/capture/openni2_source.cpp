/// @file openni2_source.cpp
/// @brief OpenNI2Source for devices and .oni playback (the only file including OpenNI.h).
#include "capture/openni2_source.h"

#include <chrono>

#include <OpenNI.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>

#include "capture/colour_stream.h"
#include "capture/device_claim.h"
#include "core/log.h"

namespace aoscan {
namespace {

constexpr int kFrameTimeoutMs = 2000;
/// The longest a depth frame waits for a colour frame that may be nearer to it in time.
constexpr int kColourWaitMs = 40;
/// The colour camera of the PrimeSense design (Carmine, Xtion) sits about 25 mm beside the depth
/// camera, along its +x axis: the nominal depth-to-colour translation when the device does not
/// register depth to colour.
constexpr double kNominalDepthToColourX = -0.025;

/// OpenNI2's last error on one line.
std::string openni_error() {
  std::string s = openni::OpenNI::getExtendedError();
  for (char& c : s)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  while (!s.empty() && s.front() == ' ') s.erase(s.begin());
  return s.empty() ? std::string("no reason given") : s;
}

/// Starts OpenNI2 once per process and keeps it up: some drivers' threads outlive
/// OpenNI::shutdown() and crash once their library is unloaded, so it is never shut down.
/// Returns an empty string on success, else why it failed.
const std::string& openni_started() {
  static const std::string problem = [] {
    if (openni::OpenNI::initialize() != openni::STATUS_OK)
      return "OpenNI2 cannot start: " + openni_error();
    return std::string();
  }();
  return problem;
}

/// The mode nearest to 640x480 @ 30 Hz in millimetre-like units; null when there is none.
const openni::VideoMode* choose_mode(const openni::SensorInfo& info) {
  const openni::Array<openni::VideoMode>& modes = info.getSupportedVideoModes();
  const openni::VideoMode* best = nullptr;
  long best_cost = 0;
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& m = modes[i];
    const openni::PixelFormat f = m.getPixelFormat();
    if (f != openni::PIXEL_FORMAT_DEPTH_1_MM && f != openni::PIXEL_FORMAT_DEPTH_100_UM) continue;
    const long cost = std::labs(m.getResolutionX() - 640L) + std::labs(m.getResolutionY() - 480L) +
                      10L * std::labs(m.getFps() - 30L) +
                      (f == openni::PIXEL_FORMAT_DEPTH_1_MM ? 0L : 1L);
    if (!best || cost < best_cost) {
      best = &m;
      best_cost = cost;
    }
  }
  return best;
}

/// The RGB888 colour mode nearest to `width` x `height` @ 30 Hz; null when there is none.
const openni::VideoMode* choose_colour_mode(const openni::SensorInfo& info, int width,
                                            int height) {
  const openni::Array<openni::VideoMode>& modes = info.getSupportedVideoModes();
  const openni::VideoMode* best = nullptr;
  long best_cost = 0;
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& m = modes[i];
    if (m.getPixelFormat() != openni::PIXEL_FORMAT_RGB888) continue;
    const long cost = std::labs(m.getResolutionX() - static_cast<long>(width)) +
                      std::labs(m.getResolutionY() - static_cast<long>(height)) +
                      10L * std::labs(m.getFps() - 30L);
    if (!best || cost < best_cost) {
      best = &m;
      best_cost = cost;
    }
  }
  return best;
}

/// Focal lengths from a stream's fields of view (radians), or 525 * width / 640 when the driver
/// reports none that is plausible; the principal point is the image centre.
Intrinsics intrinsics_from_fov(int width, int height, double hfov, double vfov) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  const bool fov_ok = std::isfinite(hfov) && std::isfinite(vfov) && hfov > 0.1 && hfov < 3.0 &&
                      vfov > 0.1 && vfov < 3.0;
  k.fx = fov_ok ? width / (2.0 * std::tan(hfov / 2.0)) : 525.0 * width / 640.0;
  k.fy = fov_ok ? height / (2.0 * std::tan(vfov / 2.0)) : k.fx;
  k.cx = (width - 1) * 0.5;
  k.cy = (height - 1) * 0.5;
  return k;
}

class OpenNI2Source : public Source {
 public:
  /// `target` is a device URI (empty: any device) or an .oni path when `file` is set.
  OpenNI2Source(const std::string& name, const std::string& target, bool file)
      : name_(name), file_(file) {
    try {
      start(target);
    } catch (...) {
      release();
      throw;
    }
  }
  ~OpenNI2Source() override { release(); }

  Status read(DepthFrame& frame) override {
    if (!colour_decided_) start_colour();
    if (!lost_.empty()) return Status::device_lost(lost_);
    if (file_ && frames_total_ >= 0 && frames_read_ >= static_cast<std::size_t>(frames_total_))
      return Status::end_of_stream();
    // Short waits up to the frame timeout, so that a stop request is seen at once; colour frames
    // that arrive meanwhile are kept for pairing.
    openni::Status wait = openni::STATUS_TIME_OUT;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kFrameTimeoutMs);
    bool have_depth = false;
    while (!have_depth && std::chrono::steady_clock::now() < deadline) {
      if (stop_requested()) return Status::end_of_stream();
      openni::VideoStream* streams[] = {&stream_, &colour_stream_};
      int ready = -1;
      wait = openni::OpenNI::waitForAnyStream(streams, colour_started_ ? 2 : 1, &ready,
                                              static_cast<int>(kStopPollInterval.count()));
      if (wait == openni::STATUS_TIME_OUT) continue;
      if (wait != openni::STATUS_OK) break;
      if (ready == 1)
        read_colour_frame();
      else
        have_depth = true;
    }
    if (!have_depth) {
      if (file_)
        return Status::bad_input(name_ + " (frame " + std::to_string(frames_read_) +
                                 "): OpenNI2 playback gave no frame within 2 s");
      lost_ = name_ + ": no depth frame for 2 s (unplugged?)";
      return Status::device_lost(lost_);
    }
    if (stream_.readFrame(&ref_) != openni::STATUS_OK || !ref_.isValid()) {
      if (file_)
        return Status::bad_input(name_ + " (frame " + std::to_string(frames_read_) +
                                 "): " + openni_error());
      lost_ = name_ + ": reading a frame failed (unplugged?): " + openni_error();
      return Status::device_lost(lost_);
    }
    ++frames_read_;
    // Live: OpenNI2's own thread received the frame just before the wait returned.
    frame.arrived_at =
        file_ ? std::chrono::steady_clock::time_point{} : std::chrono::steady_clock::now();
    const int width = ref_.getWidth();
    const int height = ref_.getHeight();
    const int stride = ref_.getStrideInBytes();
    const auto* data = static_cast<const std::uint8_t*>(ref_.getData());
    const std::string where = name_ + " (frame " + std::to_string(ref_.getFrameIndex()) + ")";
    if (!data || width <= 0 || height <= 0 || stride < 2 * width ||
        static_cast<long>(ref_.getDataSize()) <
            static_cast<long>(stride) * (height - 1) + 2L * width)
      return Status::corrupt_frame(where + ": frame buffer does not match its size");
    if (width != intrinsics_.width || height != intrinsics_.height)
      return Status::corrupt_frame(where + ": " + std::to_string(width) + "x" +
                                   std::to_string(height) + " instead of the stream's " +
                                   std::to_string(intrinsics_.width) + "x" +
                                   std::to_string(intrinsics_.height));
    if (frame.depth.width() != width || frame.depth.height() != height)
      frame.depth.resize(width, height);
    for (int y = 0; y < height; ++y)
      std::memcpy(frame.depth.row(y), data + static_cast<std::size_t>(y) * stride,
                  static_cast<std::size_t>(width) * sizeof(std::uint16_t));
    frame.depth_scale = depth_scale_;
    frame.intrinsics = intrinsics_;
    frame.timestamp_s = static_cast<double>(ref_.getTimestamp()) * 1e-6;
    frame.sequence = file_ ? frames_read_ - 1 : static_cast<std::uint64_t>(ref_.getFrameIndex());
    frame.origin = name_;
    frame.T_world_camera_gt.reset();
    pair_colour(frame, where);
    return Status::ok();
  }

  std::string name() const override { return name_; }
  std::string calibration_origin() const override { return "OpenNI2 (the device's field of view)"; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return depth_scale_; }
  std::optional<std::size_t> size() const override {
    if (!file_ || frames_total_ < 0) return std::nullopt;
    return static_cast<std::size_t>(frames_total_);
  }
  bool live() const override { return !file_; }
  std::string colour_origin() const override { return colour_camera_ ? colour_origin_ : ""; }

 private:
  /// The colour stream, before the first read: created and started when the device (or file)
  /// has one and colour is wanted; a failure leaves the source depth-only, with a warning.
  void start_colour() {
    colour_decided_ = true;
    if (!colour_camera_ || !colour_wanted()) {
      colour_camera_.reset();
      return;
    }
    const auto give_up = [&](const std::string& why) {
      spdlog::warn("{}: {}; continuing without colour", name_, why);
      colour_camera_.reset();
      colour_stream_.destroy();
    };
    if (colour_stream_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK)
      return give_up("cannot create the colour stream: " + openni_error());
    if (!file_) {
      if (const openni::SensorInfo* info = device_.getSensorInfo(openni::SENSOR_COLOR))
        if (const openni::VideoMode* mode = choose_colour_mode(*info, colour_width_, colour_height_))
          if (colour_stream_.setVideoMode(*mode) != openni::STATUS_OK)
            spdlog::info("{}: keeping the driver's colour mode ({})", name_, openni_error());
      if (colour_stream_.isPropertySupported(openni::STREAM_PROPERTY_MIRRORING))
        colour_stream_.setMirroringEnabled(false);
    }
    const openni::VideoMode mode = colour_stream_.getVideoMode();
    if (mode.getPixelFormat() != openni::PIXEL_FORMAT_RGB888)
      return give_up("the colour stream is not RGB888 (pixel format " +
                     std::to_string(static_cast<int>(mode.getPixelFormat())) + ")");
    // The mode the driver settled on sets the colour camera's size, the stream its field of view.
    colour_camera_ = colour_camera_for(mode.getResolutionX(), mode.getResolutionY(),
                                       colour_stream_.getHorizontalFieldOfView(),
                                       colour_stream_.getVerticalFieldOfView());
    if (colour_stream_.start() != openni::STATUS_OK)
      return give_up("cannot start the colour stream: " + openni_error());
    colour_started_ = true;
  }

  /// The colour camera for colour frames of `width` x `height`: registered when the device
  /// registers depth to colour, else nominal beside the depth camera.
  ColourCamera colour_camera_for(int width, int height, double hfov, double vfov) const {
    if (registered_) return registered_colour_camera(intrinsics_, width, height);
    ColourCamera c = ColourCamera::nominal(width, height, kNominalDepthToColourX);
    c.intrinsics = intrinsics_from_fov(width, height, hfov, vfov);
    return c;
  }

  /// Reads the colour frame waitForAnyStream reported into the pairer.
  void read_colour_frame() {
    if (colour_stream_.readFrame(&colour_ref_) != openni::STATUS_OK || !colour_ref_.isValid())
      return;  // nothing to pair; a depth frame near it says so
    const double timestamp_s = static_cast<double>(colour_ref_.getTimestamp()) * 1e-6;
    const Status s = decode_colour_frame(
        ColourPixelFormat::kRgb24, static_cast<const std::uint8_t*>(colour_ref_.getData()),
        colour_ref_.getData() ? static_cast<std::size_t>(std::max(0, colour_ref_.getDataSize()))
                              : 0,
        colour_ref_.getWidth(), colour_ref_.getHeight(), colour_ref_.getStrideInBytes(),
        pairer_.next_buffer(),
        name_ + " (colour frame " + std::to_string(colour_ref_.getFrameIndex()) + ")");
    colour_ref_.release();
    if (s.is_ok())
      pairer_.commit(timestamp_s);
    else
      pairer_.commit_failed(timestamp_s, s.message());
  }

  /// The depth frame just read gets its colour: the colour frames already there are taken in,
  /// and while the colour stream is behind it waits up to kColourWaitMs for a nearer one (the
  /// next depth frame waits in OpenNI2's queue meanwhile).
  void pair_colour(DepthFrame& frame, const std::string& where) {
    if (!colour_started_) {
      frame.clear_colour();
      return;
    }
    openni::VideoStream* streams[] = {&colour_stream_};
    int ready = -1;
    while (openni::OpenNI::waitForAnyStream(streams, 1, &ready, 0) == openni::STATUS_OK)
      read_colour_frame();
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::milliseconds(kColourWaitMs);
    while (pairer_.worth_waiting(frame.timestamp_s) && !stop_requested() &&
           std::chrono::steady_clock::now() < deadline) {
      const openni::Status wait = openni::OpenNI::waitForAnyStream(streams, 1, &ready, 10);
      if (wait == openni::STATUS_OK)
        read_colour_frame();
      else if (wait != openni::STATUS_TIME_OUT)
        break;
    }
    pairer_.pair(frame, *colour_camera_, where);
  }

  [[noreturn]] void fail(const std::string& what) const {
    if (file_) throw input_error(name_ + ": " + what);
    throw device_error(name_ + ": " + what);
  }

  void start(const std::string& target) {
    const std::string& problem = openni_started();
    if (!problem.empty()) fail(problem);
    if (!file_) claim_ = DeviceClaim("openni2:" + target, name_);
    const char* uri = target.empty() ? openni::ANY_DEVICE : target.c_str();
    if (device_.open(uri) != openni::STATUS_OK)
      fail(std::string(file_            ? "not a recording OpenNI2 can open: "
                       : target.empty() ? "no OpenNI2 device could be opened: "
                                        : "cannot open the device: ") +
           openni_error());
    const openni::SensorInfo* info = device_.getSensorInfo(openni::SENSOR_DEPTH);
    if (!info) fail(file_ ? "holds no depth stream" : "has no depth sensor");
    if (stream_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK)
      fail("cannot create the depth stream: " + openni_error());

    if (file_) {
      openni::PlaybackControl* playback = device_.getPlaybackControl();
      if (!playback) fail("OpenNI2 offers no playback control for it");
      playback->setRepeatEnabled(false);
      playback->setSpeed(-1.0f);
      frames_total_ = playback->getNumberOfFrames(stream_);
    } else {
      const openni::VideoMode* mode = choose_mode(*info);
      if (!mode) fail("offers no depth mode in millimetres");
      if (stream_.setVideoMode(*mode) != openni::STATUS_OK)
        spdlog::info("{}: keeping the driver's depth mode ({})", name_, openni_error());
      if (stream_.isPropertySupported(openni::STREAM_PROPERTY_MIRRORING) &&
          stream_.setMirroringEnabled(false) != openni::STATUS_OK)
        spdlog::warn("{}: cannot turn mirroring off: {}", name_, openni_error());
    }

    const openni::VideoMode mode = stream_.getVideoMode();
    if (mode.getPixelFormat() != openni::PIXEL_FORMAT_DEPTH_1_MM &&
        mode.getPixelFormat() != openni::PIXEL_FORMAT_DEPTH_100_UM)
      fail("the depth stream is not in millimetre-like units (pixel format " +
           std::to_string(static_cast<int>(mode.getPixelFormat())) + ")");
    depth_scale_ = mode.getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_1_MM ? 1000.0 : 10000.0;
    // Colour: the device's (or the file's) colour sensor, when it offers RGB888. A live device
    // that can register depth to colour does so (whether or not colour is fused, so that the
    // depth's geometry never depends on fusion.colour), before the depth's field of view is read;
    // a recording is as it was recorded.
    const openni::SensorInfo* colour = device_.getSensorInfo(openni::SENSOR_COLOR);
    const openni::VideoMode* colour_mode =
        colour && !file_
            ? choose_colour_mode(*colour, mode.getResolutionX(), mode.getResolutionY())
            : nullptr;
    const bool has_colour = colour && (file_ || colour_mode);
    if (has_colour && !file_ &&
        device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) &&
        device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) ==
            openni::STATUS_OK)
      registered_ = true;
    if (has_colour && file_)
      registered_ =
          device_.getImageRegistrationMode() == openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR;

    intrinsics_ = intrinsics_from_fov(mode.getResolutionX(), mode.getResolutionY(),
                                      stream_.getHorizontalFieldOfView(),
                                      stream_.getVerticalFieldOfView());
    if (!intrinsics_.valid()) fail("the depth stream reports no usable size");

    if (has_colour) {
      // A recording's colour size is known once its stream exists (start_colour()).
      colour_width_ = colour_mode ? colour_mode->getResolutionX() : intrinsics_.width;
      colour_height_ = colour_mode ? colour_mode->getResolutionY() : intrinsics_.height;
      colour_camera_ = colour_camera_for(colour_width_, colour_height_, 0.0, 0.0);
      colour_origin_ = registered_ ? "OpenNI2 (the device registers depth to colour)"
                                   : "nominal (no depth-to-colour registration: the colour "
                                     "stream's field of view, 25 mm beside the depth camera)";
    }

    if (stream_.start() != openni::STATUS_OK)
      fail("cannot start the depth stream: " + openni_error());
    started_ = true;
  }

  void release() {
    colour_ref_.release();
    if (colour_started_) colour_stream_.stop();
    colour_started_ = false;
    colour_stream_.destroy();
    ref_.release();
    if (started_) stream_.stop();
    started_ = false;
    stream_.destroy();
    device_.close();
  }

  std::string name_;
  bool file_;
  DeviceClaim claim_;
  openni::Device device_;
  openni::VideoStream stream_;
  openni::VideoFrameRef ref_;
  bool started_ = false;
  double depth_scale_ = 1000.0;
  Intrinsics intrinsics_;
  int frames_total_ = -1;
  // Colour: the camera while the source delivers colour (set on open when there is a colour
  // sensor, reset when colour is not wanted or fails to start).
  std::optional<ColourCamera> colour_camera_;
  std::string colour_origin_;
  bool registered_ = false;
  int colour_width_ = 0;
  int colour_height_ = 0;
  bool colour_decided_ = false;
  bool colour_started_ = false;
  openni::VideoStream colour_stream_;
  openni::VideoFrameRef colour_ref_;
  ColourPairer pairer_;
  std::size_t frames_read_ = 0;
  std::string lost_;
};

}  // namespace

std::unique_ptr<Source> open_openni2_source(const std::string& uri) {
  const std::string prefix = "openni2";
  if (uri.compare(0, prefix.size(), prefix) != 0) throw usage_error(uri + ": not an openni2 URI");
  std::string target = uri.substr(prefix.size());
  if (!target.empty()) {
    if (target[0] != ':' || target.size() == 1)
      throw usage_error(uri + ": expected openni2 or openni2:URI");
    target.erase(0, 1);
  }
  return std::make_unique<OpenNI2Source>(uri, target, false);
}

std::unique_ptr<Source> open_oni_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw input_error(path + ": no such OpenNI2 recording");
  return std::make_unique<OpenNI2Source>(path, path, true);
}

std::vector<DeviceInfo> list_openni2_devices() {
  std::vector<DeviceInfo> found;
  if (!openni_started().empty()) return found;
  openni::Array<openni::DeviceInfo> devices;
  openni::OpenNI::enumerateDevices(&devices);
  for (int i = 0; i < devices.getSize(); ++i) {
    const openni::DeviceInfo& d = devices[i];
    found.push_back({"openni2:" + std::string(d.getUri()),
                     std::string(d.getVendor()) + " " + d.getName() + " (OpenNI2)"});
  }
  return found;
}

}  // namespace aoscan
