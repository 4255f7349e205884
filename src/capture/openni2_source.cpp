/// @file openni2_source.cpp
/// @brief OpenNI2Source for devices and .oni playback (the only file including OpenNI.h).
#include "capture/openni2_source.h"

#include <chrono>

#include <OpenNI.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>

#include "capture/device_claim.h"
#include "core/log.h"

namespace aoscan {
namespace {

constexpr int kFrameTimeoutMs = 2000;

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
    if (!lost_.empty()) return Status::device_lost(lost_);
    if (file_ && frames_total_ >= 0 && frames_read_ >= static_cast<std::size_t>(frames_total_))
      return Status::end_of_stream();
    openni::VideoStream* streams[] = {&stream_};
    int ready = -1;
    // Short waits up to the frame timeout, so that a stop request is seen at once.
    openni::Status wait = openni::STATUS_TIME_OUT;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kFrameTimeoutMs);
    while (wait == openni::STATUS_TIME_OUT && std::chrono::steady_clock::now() < deadline) {
      if (stop_requested()) return Status::end_of_stream();
      wait = openni::OpenNI::waitForAnyStream(
          streams, 1, &ready, static_cast<int>(kStopPollInterval.count()));
    }
    if (wait != openni::STATUS_OK) {
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

 private:
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
    intrinsics_.width = mode.getResolutionX();
    intrinsics_.height = mode.getResolutionY();
    const double hfov = stream_.getHorizontalFieldOfView();
    const double vfov = stream_.getVerticalFieldOfView();
    const bool fov_ok = std::isfinite(hfov) && std::isfinite(vfov) && hfov > 0.1 && hfov < 3.0 &&
                        vfov > 0.1 && vfov < 3.0;
    intrinsics_.fx = fov_ok ? intrinsics_.width / (2.0 * std::tan(hfov / 2.0))
                            : 525.0 * intrinsics_.width / 640.0;
    intrinsics_.fy = fov_ok ? intrinsics_.height / (2.0 * std::tan(vfov / 2.0)) : intrinsics_.fx;
    intrinsics_.cx = (intrinsics_.width - 1) * 0.5;
    intrinsics_.cy = (intrinsics_.height - 1) * 0.5;
    if (!intrinsics_.valid()) fail("the depth stream reports no usable size");

    if (stream_.start() != openni::STATUS_OK)
      fail("cannot start the depth stream: " + openni_error());
    started_ = true;
  }

  void release() {
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
