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

#include "capture/device_claim.h"
#include "capture/fakenect_dump.h"
#include "capture/kinect_disparity.h"
#include "core/log.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

constexpr auto kFrameTimeout = std::chrono::seconds(2);

/// Kinect v1 depth camera calibration (the 7-Scenes / common Kinect values), and the RGB
/// camera's for the registered mm mode.
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
      : LiveMillimetreSource(uri), depth_mm_(parsed.depth_mm) {
    intrinsics_ = parsed.depth_mm ? kinect_rgb_intrinsics() : kinect_depth_intrinsics();
    const bool fake = fakenect_loaded();
    if (fake) {
      const std::string problem = fakenect_problem();
      if (!problem.empty()) throw device_error(uri + ": " + problem);
      if (parsed.depth_mm)
        throw device_error(uri + ": fakenect replays raw 11-bit depth only; drop ?depth=mm");
    }
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
    const freenect_frame_mode mode = freenect_find_depth_mode(
        FREENECT_RESOLUTION_MEDIUM, parsed.depth_mm ? FREENECT_DEPTH_MM : FREENECT_DEPTH_11BIT);
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
      if (started_) freenect_stop_depth(device_);
      freenect_close_device(device_);
    }
  }

  Status read(DepthFrame& frame) override {
    if (!lost_.empty()) return Status::device_lost(lost_);
    target_ = &frame;
    delivered_ = false;
    const auto deadline = Clock::now() + kFrameTimeout;
    while (!delivered_) {
      if (stop_requested()) break;
      timeval timeout{0, std::chrono::microseconds(kStopPollInterval).count()};
      const int rc = freenect_process_events_timeout(context_->get(), &timeout);
      if (rc < 0) {
        lost_ = name_ + ": the Kinect stopped delivering frames (unplugged?): libfreenect error " +
                std::to_string(rc);
        break;
      }
      if (!delivered_ && Clock::now() > deadline) {
        lost_ = name_ + ": no depth frame for 2 s (unplugged?)";
        break;
      }
    }
    target_ = nullptr;
    if (!delivered_) return lost_.empty() ? Status::end_of_stream() : Status::device_lost(lost_);
    stamp(frame, static_cast<double>(ticks_) / kKinectClockHz, sequence_++);
    return Status::ok();
  }

 private:
  static void on_depth(freenect_device* device, void* depth, std::uint32_t timestamp) {
    auto* self = static_cast<FreenectSource*>(freenect_get_user(device));
    if (self) self->deliver(depth, timestamp);
  }

  /// Runs inside freenect_process_events, on the reading thread.
  void deliver(const void* depth, std::uint32_t timestamp) {
    if (!target_) return;                // a callback outside read(): nobody asked, nothing to fill
    target_->arrived_at = Clock::now();  // the capture latency starts at the driver's callback
    if (delivered_) ++frames_overwritten_;  // two frames in one call: the newer wins
    Image<std::uint16_t>& out = target_->depth;
    if (out.width() != kFakenectWidth || out.height() != kFakenectHeight)
      out.resize(kFakenectWidth, kFakenectHeight);
    const std::size_t count = out.size();
    if (depth_mm_) {
      std::memcpy(out.data(), depth, count * sizeof(std::uint16_t));
    } else {
      kinect_raw_to_mm(depth, count, out.data());
    }
    if (have_tick_) {
      ticks_ += static_cast<std::uint32_t>(timestamp - last_tick_);  // unwraps the 32-bit clock
    } else {
      ticks_ = timestamp;
      have_tick_ = true;
    }
    last_tick_ = timestamp;
    delivered_ = true;
  }

  bool depth_mm_;
  DeviceClaim claim_;
  std::unique_ptr<FreenectContext> context_;
  freenect_device* device_ = nullptr;
  bool started_ = false;
  DepthFrame* target_ = nullptr;
  bool delivered_ = false;
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
      throw usage_error(uri + ": expected freenect[:INDEX][?depth=raw|mm]");
    parsed.index = std::stoi(rest.substr(1));
  }
  if (!query.empty()) {
    if (query == "depth=mm") {
      parsed.depth_mm = true;
    } else if (query != "depth=raw") {
      throw usage_error(uri + ": unknown option '" + query + "' (depth=raw or depth=mm)");
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
  for (int i = 0; i < count; ++i)
    found.push_back({"freenect:" + std::to_string(i), what + ", 640x480 11-bit depth"});
  return found;
}

}  // namespace aoscan
