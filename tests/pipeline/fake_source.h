/// @file fake_source.h
/// @brief An in-memory Source for pipeline tests: numbered tiny frames, optional pacing and faults.
#pragma once

#include <chrono>
#include <set>
#include <thread>

#include "capture/source.h"

namespace aoscan::testing {

class FakeSource : public Source {
 public:
  explicit FakeSource(std::size_t frames, bool live = false) : frames_(frames), live_(live) {
    intrinsics_.width = 8;
    intrinsics_.height = 6;
  }

  Status read(DepthFrame& frame) override {
    if (next_ >= frames_) return Status::end_of_stream();
    const std::size_t index = next_++;
    if (period_.count() > 0) std::this_thread::sleep_for(period_);
    if (corrupt_.count(index)) return Status::corrupt_frame("fake frame " + std::to_string(index));
    if (fail_at_ && index == *fail_at_) return Status::device_lost("fake camera unplugged");
    frame.depth.resize(intrinsics_.width, intrinsics_.height, 1000);
    frame.depth_scale = 1000.0;
    frame.intrinsics = intrinsics_;
    frame.sequence = index;
    frame.timestamp_s = static_cast<double>(index) / 30.0;
    frame.origin = "fake";
    last_read_ = std::chrono::steady_clock::now();
    return Status::ok();
  }
  std::string name() const override { return "fake"; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return 1000.0; }
  std::optional<std::size_t> size() const override { return frames_; }
  bool live() const override { return live_; }

  std::chrono::microseconds period_{0};
  std::set<std::size_t> corrupt_;
  std::optional<std::size_t> fail_at_;
  std::chrono::steady_clock::time_point last_read_;
  std::size_t next_ = 0;

 private:
  std::size_t frames_;
  bool live_;
  Intrinsics intrinsics_;
};

}  // namespace aoscan::testing
