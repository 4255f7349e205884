/// @file freenect_source.cpp
/// @brief FreenectSource: libfreenect's callback API driven from Source::read().
#include "capture/freenect_source.h"

#include <dlfcn.h>
#include <libfreenect.h>
#include <sys/time.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <utility>

#include "capture/colour_stream.h"
#include "capture/device_claim.h"
#include "capture/fakenect_dump.h"
#include "capture/kinect_disparity.h"
#include "core/log.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

constexpr auto kFrameTimeout = std::chrono::seconds(2);
/// The longest a depth frame waits for a colour frame that may be nearer to it in time.
constexpr auto kColourWait = std::chrono::milliseconds(40);
/// Kinect v1: the RGB camera sits about 25 mm beside the IR (depth) camera, along the depth
/// camera's +x axis (RedKitchen's estimate: 25.1 mm), so a depth-camera point has x - 0.025 m in
/// the RGB camera's frame.
constexpr double kKinectDepthToColourX = -0.025;

/// Kinect v1 depth camera calibration (the 7-Scenes / common Kinect values), and the RGB
/// camera's (the depth's in the registered mode, which resamples depth onto the RGB pixels).
Intrinsics kinect_depth_intrinsics() {
  Intrinsics k;
  k.width = kFakenectWidth;
  k.height = kFakenectHeight;
  k.fx = k.fy = 585.0;
  k.cx = 320.0;
  k.cy = 240.0;
  return k;
}
Intrinsics kinect_rgb_intrinsics() {
  Intrinsics k;
  k.width = kFakenectWidth;
  k.height = kFakenectHeight;
  k.fx = k.fy = 525.0;
  k.cx = 319.5;
  k.cy = 239.5;
  return k;
}

/// True when the libfreenect in this process is fakenect (it exits the process on a missing
/// dump, so we check the dump first).
bool fakenect_loaded() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&freenect_init), &info) == 0 || !info.dli_fname) return false;
  return std::strstr(info.dli_fname, "fakenect") != nullptr;
}

/// Empty when fakenect can start, else why not.
std::string fakenect_problem() {
  const char* path = std::getenv("FAKENECT_PATH");
  if (!path || !*path) return "fakenect is loaded but FAKENECT_PATH is not set";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(std::filesystem::path(path) / "INDEX.txt", ec))
    return std::string("fakenect: ") + path + "/INDEX.txt does not exist";
  return {};
}

/// True when the fakenect dump at FAKENECT_PATH holds video frames (`r-*` lines in INDEX.txt).
bool fakenect_dump_has_video() {
  const char* path = std::getenv("FAKENECT_PATH");
  if (!path) return false;
  std::ifstream index(std::filesystem::path(path) / "INDEX.txt");
  for (std::string line; std::getline(index, line);)
    if (line.rfind("r-", 0) == 0) return true;
  return false;
}

class FreenectContext {
 public:
  FreenectContext() {
    if (freenect_init(&ctx_, nullptr) < 0) ctx_ = nullptr;
    if (ctx_) {
      freenect_set_log_level(ctx_, FREENECT_LOG_FATAL);
      freenect_select_subdevices(ctx_, FREENECT_DEVICE_CAMERA);
    }
  }
  ~FreenectContext() {
    if (ctx_) freenect_shutdown(ctx_);
  }
  FreenectContext(const FreenectContext&) = delete;
  FreenectContext& operator=(const FreenectContext&) = delete;
  freenect_context* get() const { return ctx_; }

 private:
  freenect_context* ctx_ = nullptr;
};

class FreenectSource : public LiveMillimetreSource {
 public:
  FreenectSource(const std::string& uri, const FreenectUri& parsed)
      : LiveMillimetreSource(uri), depth_(parsed.depth) {
    // Raw disparity and the driver's mm mode are in the depth (IR) camera's pixels; the
    // registered mode resamples depth onto the RGB camera's.
    intrinsics_ = depth_ == FreenectDepth::kRegistered ? kinect_rgb_intrinsics()
                                                       : kinect_depth_intrinsics();
    const bool fake = fakenect_loaded();
    if (fake) {
      const std::string problem = fakenect_problem();
      if (!problem.empty()) throw device_error(uri + ": " + problem);
      if (depth_ != FreenectDepth::kRaw)
        throw device_error(uri + ": fakenect replays raw 11-bit depth only; drop ?depth=" +
                           (depth_ == FreenectDepth::kMm ? "mm" : "registered"));
    }
    // A fakenect dump without video frames is a depth-only camera; a Kinect always has RGB.
    has_video_ = !fake || fakenect_dump_has_video();
    if (has_video_)
      colour_camera_ = depth_ == FreenectDepth::kRegistered
                           ? ColourCamera::registered_to(intrinsics_)
                           : ColourCamera::nominal(kFakenectWidth, kFakenectHeight,
                                                   kKinectDepthToColourX);
    claim_ = DeviceClaim("freenect:" + std::to_string(parsed.index), uri);
    context_ = std::make_unique<FreenectContext>();
    if (!context_->get()) throw device_error(uri + ": libfreenect cannot start (libusb failed)");
    const int count = freenect_num_devices(context_->get());
    if (parsed.index >= count)
      throw device_error(uri + ": no such Kinect (libfreenect sees " + std::to_string(count) + ")");
    if (freenect_open_device(context_->get(), &device_, parsed.index) < 0 || !device_) {
      device_ = nullptr;
      throw device_error(uri +
                         ": cannot open the Kinect (busy in another program, or no "
                         "permission: add yourself to the plugdev group)");
    }
    const freenect_depth_format format = depth_ == FreenectDepth::kMm ? FREENECT_DEPTH_MM
                                         : depth_ == FreenectDepth::kRegistered
                                             ? FREENECT_DEPTH_REGISTERED
                                             : FREENECT_DEPTH_11BIT;
    const freenect_frame_mode mode = freenect_find_depth_mode(FREENECT_RESOLUTION_MEDIUM, format);
    if (!mode.is_valid || mode.width != kFakenectWidth || mode.height != kFakenectHeight ||
        freenect_set_depth_mode(device_, mode) < 0)
      throw device_error(uri + ": the Kinect refuses 640x480 depth");
    freenect_set_user(device_, this);
    freenect_set_depth_callback(device_, &FreenectSource::on_depth);
    if (freenect_start_depth(device_) < 0)
      throw device_error(uri + ": cannot start the depth stream");
    started_ = true;
  }

  ~FreenectSource() override {
    if (frames_overwritten_ > 0)
      spdlog::info("{}: {} frames replaced by newer ones before they were read", name_,
                   frames_overwritten_);
    if (device_) {
      if (video_started_) freenect_stop_video(device_);
      if (started_) freenect_stop_depth(device_);
      freenect_close_device(device_);
    }
  }

  std::string colour_origin() const override {
    if (!colour_camera_) return "";
    return depth_ == FreenectDepth::kRegistered
               ? "libfreenect (depth registered to the RGB camera)"
               : "nominal Kinect v1 RGB camera (fx = fy = 525, 25 mm beside the depth camera)";
  }

  Status read(DepthFrame& frame) override {
    if (!colour_decided_) start_colour();
    if (!lost_.empty() && !depth_ready_) return Status::device_lost(lost_);
    const auto deadline = Clock::now() + kFrameTimeout;
    while (!depth_ready_) {
      if (stop_requested()) return Status::end_of_stream();
      if (!process_events()) return Status::device_lost(lost_);
      if (!depth_ready_ && Clock::now() > deadline) {
        lost_ = name_ + ": no depth frame for 2 s (unplugged?)";
        return Status::device_lost(lost_);
      }
    }
    std::swap(frame.depth, depth_buffer_);
    depth_ready_ = false;
    frame.arrived_at = depth_arrived_;
    const double timestamp_s = static_cast<double>(depth_ticks_) / kKinectClockHz;
    const std::uint64_t sequence = sequence_++;
    stamp(frame, timestamp_s, sequence);
    if (!video_started_) {
      frame.clear_colour();
      return Status::ok();
    }
    // Its colour: when the RGB stream is behind, wait briefly for a nearer frame, but never past
    // the next depth frame (kept for the next read) or a stopped stream.
    const auto colour_deadline = Clock::now() + kColourWait;
    while (lost_.empty() && !depth_ready_ && !stop_requested() &&
           pairer_.worth_waiting(timestamp_s) && Clock::now() < colour_deadline)
      if (!process_events()) break;
    pairer_.pair(frame, *colour_camera_, name_ + " (frame " + std::to_string(sequence) + ")");
    return Status::ok();
  }

 private:
  /// One round of libfreenect's events; false (lost_ set) when libfreenect fails.
  bool process_events() {
    timeval timeout{0, std::chrono::microseconds(kStopPollInterval).count()};
    const int rc = freenect_process_events_timeout(context_->get(), &timeout);
    if (rc >= 0) return true;
    lost_ = name_ + ": the Kinect stopped delivering frames (unplugged?): libfreenect error " +
            std::to_string(rc);
    return false;
  }

  /// Starts the RGB stream before the first read, when the camera has one and colour is wanted.
  void start_colour() {
    colour_decided_ = true;
    if (!colour_camera_ || !colour_wanted()) {
      colour_camera_.reset();
      return;
    }
    const freenect_frame_mode mode =
        freenect_find_video_mode(FREENECT_RESOLUTION_MEDIUM, FREENECT_VIDEO_RGB);
    if (!mode.is_valid || mode.width != kFakenectWidth || mode.height != kFakenectHeight ||
        freenect_set_video_mode(device_, mode) < 0) {
      spdlog::warn("{}: the Kinect refuses 640x480 RGB; continuing without colour", name_);
      colour_camera_.reset();
      return;
    }
    freenect_set_video_callback(device_, &FreenectSource::on_video);
    if (freenect_start_video(device_) < 0) {
      spdlog::warn("{}: cannot start the RGB stream; continuing without colour", name_);
      colour_camera_.reset();
      return;
    }
    video_started_ = true;
  }

  static void on_depth(freenect_device* device, void* depth, std::uint32_t timestamp) {
    auto* self = static_cast<FreenectSource*>(freenect_get_user(device));
    if (self) self->deliver(depth, timestamp);
  }
  static void on_video(freenect_device* device, void* rgb, std::uint32_t timestamp) {
    auto* self = static_cast<FreenectSource*>(freenect_get_user(device));
    if (self) self->deliver_video(rgb, timestamp);
  }

  /// Runs inside freenect_process_events, on the reading thread.
  void deliver(const void* depth, std::uint32_t timestamp) {
    depth_arrived_ = Clock::now();  // the capture latency starts at the driver's callback
    if (depth_ready_) ++frames_overwritten_;  // two frames before a read: the newer wins
    Image<std::uint16_t>& out = depth_buffer_;
    if (out.width() != kFakenectWidth || out.height() != kFakenectHeight)
      out.resize(kFakenectWidth, kFakenectHeight);
    const std::size_t count = out.size();
    if (depth_ == FreenectDepth::kRaw) {
      kinect_raw_to_mm(depth, count, out.data());
    } else {
      std::memcpy(out.data(), depth, count * sizeof(std::uint16_t));
    }
    if (have_tick_) {
      ticks_ += static_cast<std::uint32_t>(timestamp - last_tick_);  // unwraps the 32-bit clock
    } else {
      ticks_ = timestamp;
      have_tick_ = true;
    }
    last_tick_ = timestamp;
    depth_ticks_ = ticks_;
    depth_ready_ = true;
  }

  /// An RGB frame (640x480x3), on the depth frames' clock: its 32-bit timestamp is read as a
  /// signed offset from the last depth frame's (the two streams share the Kinect's clock).
  void deliver_video(const void* rgb, std::uint32_t timestamp) {
    if (!have_tick_) {
      ticks_ = timestamp;
      last_tick_ = timestamp;
      have_tick_ = true;
    }
    const auto offset = static_cast<std::int32_t>(timestamp - last_tick_);
    const double timestamp_s =
        (static_cast<double>(ticks_) + static_cast<double>(offset)) / kKinectClockHz;
    const Status s = decode_colour_frame(
        ColourPixelFormat::kRgb24, static_cast<const std::uint8_t*>(rgb),
        static_cast<std::size_t>(kFakenectWidth) * kFakenectHeight * 3, kFakenectWidth,
        kFakenectHeight, kFakenectWidth * 3, pairer_.next_buffer(), name_ + " (RGB frame)");
    if (s.is_ok())
      pairer_.commit(timestamp_s);
    else
      pairer_.commit_failed(timestamp_s, s.message());
  }

  FreenectDepth depth_;
  bool has_video_ = false;
  std::optional<ColourCamera> colour_camera_;  ///< set while the source delivers colour
  bool colour_decided_ = false;
  bool video_started_ = false;
  ColourPairer pairer_;
  DeviceClaim claim_;
  std::unique_ptr<FreenectContext> context_;
  freenect_device* device_ = nullptr;
  bool started_ = false;
  Image<std::uint16_t> depth_buffer_;  ///< the newest depth frame, until a read takes it
  bool depth_ready_ = false;
  Clock::time_point depth_arrived_{};
  std::uint64_t depth_ticks_ = 0;
  std::string lost_;
  std::uint64_t ticks_ = 0;
  std::uint32_t last_tick_ = 0;
  bool have_tick_ = false;
  std::uint64_t sequence_ = 0;
  std::size_t frames_overwritten_ = 0;
};

}  // namespace

FreenectUri parse_freenect_uri(const std::string& uri) {
  const std::string prefix = "freenect";
  if (uri.compare(0, prefix.size(), prefix) != 0) throw usage_error(uri + ": not a freenect URI");
  std::string rest = uri.substr(prefix.size());
  std::string query;
  if (const auto q = rest.find('?'); q != std::string::npos) {
    query = rest.substr(q + 1);
    rest.resize(q);
  }
  FreenectUri parsed;
  if (!rest.empty()) {
    if (rest[0] != ':' || rest.size() == 1 || rest.size() > 4 ||
        rest.find_first_not_of("0123456789", 1) != std::string::npos)
      throw usage_error(uri + ": expected freenect[:INDEX][?depth=raw|mm|registered]");
    parsed.index = std::stoi(rest.substr(1));
  }
  if (!query.empty()) {
    if (query == "depth=mm") {
      parsed.depth = FreenectDepth::kMm;
    } else if (query == "depth=registered") {
      parsed.depth = FreenectDepth::kRegistered;
    } else if (query != "depth=raw") {
      throw usage_error(uri + ": unknown option '" + query +
                        "' (depth=raw, depth=mm or depth=registered)");
    }
  }
  return parsed;
}

std::unique_ptr<Source> open_freenect_source(const std::string& uri) {
  return std::make_unique<FreenectSource>(uri, parse_freenect_uri(uri));
}

std::vector<DeviceInfo> list_freenect_devices() {
  std::vector<DeviceInfo> found;
  if (fakenect_loaded() && !fakenect_problem().empty()) return found;
  FreenectContext context;
  if (!context.get()) return found;
  const int count = freenect_num_devices(context.get());
  const std::string what = fakenect_loaded() ? "Kinect v1 (fakenect replay of " +
                                                   std::string(std::getenv("FAKENECT_PATH")) + ")"
                                             : "Kinect v1 (libfreenect)";
  const bool video = !fakenect_loaded() || fakenect_dump_has_video();
  for (int i = 0; i < count; ++i)
    found.push_back({"freenect:" + std::to_string(i),
                     what + (video ? ", 640x480 11-bit depth and RGB" : ", 640x480 11-bit depth")});
  return found;
}

}  // namespace aoscan
