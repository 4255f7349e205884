/// @file loop_source.cpp
/// @brief The ping-pong loop over a seekable source (`replay --loop N`).
#include "capture/loop_source.h"

#include <optional>
#include <string>
#include <utility>

#include "core/status.h"

namespace aoscan {
namespace {

class LoopSource final : public Source {
 public:
  LoopSource(std::unique_ptr<Source> inner, std::size_t passes)
      : inner_(std::move(inner)), passes_(passes), n_(*inner_->size()) {}

  Status read(DepthFrame& frame) override {
    if (!forwarded_) {
      forward_settings(*inner_);
      forwarded_ = true;
    }
    while (pass_ < passes_ && n_ > 0) {
      if (pos_ >= n_) {
        ++pass_;
        pos_ = 0;
        continue;
      }
      const bool forward = pass_ % 2 == 0;
      const std::size_t index = forward ? pos_ : n_ - 1 - pos_;
      // Pass 0 reads the source in its own order; later passes place every backward frame and
      // the start of every forward pass.
      if (!forward || (pass_ > 0 && pos_ == 0)) {
        if (Status s = inner_->seek(index); !s.is_ok()) return s;
      }
      Status s = inner_->read(frame);
      if (s.code() == Status::Code::kEndOfStream) {
        if (pass_ > 0) return Status::internal(inner_->name() + ": ended before frame " +
                                               std::to_string(index) + " it had in the first pass");
        n_ = pos_;  // shorter than it said: a pass is what the first pass found
        continue;
      }
      const std::uint64_t position = static_cast<std::uint64_t>(pass_) * n_ + pos_;
      ++pos_;
      if (!s.is_ok()) return s;  // corrupt_frame goes on with the next; errors stop the caller
      if (pass_ == 0) {
        if (!first_ts_) first_ts_ = frame.timestamp_s;
        last_ts_ = frame.timestamp_s;
      } else {
        const double span = last_ts_ - *first_ts_;
        const double step = n_ > 1 && span > 0 ? span / static_cast<double>(n_ - 1)
                                               : kLoopFallbackFrameInterval;
        const double pass_start = *first_ts_ + static_cast<double>(pass_) * (span + step);
        frame.timestamp_s = pass_start + (forward ? frame.timestamp_s - *first_ts_
                                                  : last_ts_ - frame.timestamp_s);
      }
      frame.sequence = position;
      return Status::ok();
    }
    return Status::end_of_stream();
  }

  std::string name() const override { return inner_->name(); }
  const Intrinsics& intrinsics() const override { return inner_->intrinsics(); }
  double depth_scale() const override { return inner_->depth_scale(); }
  std::string calibration_origin() const override { return inner_->calibration_origin(); }
  bool calibration_is_default() const override { return inner_->calibration_is_default(); }
  std::optional<std::size_t> size() const override { return passes_ * n_; }
  const TriangleMesh* scene_mesh() const override { return inner_->scene_mesh(); }

 private:
  std::unique_ptr<Source> inner_;
  bool forwarded_ = false;  ///< the stop flag and colour choice handed on to inner_
  std::size_t passes_;
  std::size_t n_;         ///< frames per pass
  std::size_t pass_ = 0;  ///< the pass being read
  std::size_t pos_ = 0;   ///< the next position within it
  std::optional<double> first_ts_;  ///< first pass: timestamp of its first readable frame
  double last_ts_ = 0.0;            ///< ... and of its last one
};

}  // namespace

std::unique_ptr<Source> make_loop_source(std::unique_ptr<Source> inner, std::int64_t passes) {
  if (passes < kMinLoopPasses || passes > kMaxLoopPasses)
    throw usage_error("--loop " + std::to_string(passes) + ": the number of passes must be " +
                      std::to_string(kMinLoopPasses) + " to " + std::to_string(kMaxLoopPasses));
  if (!inner->seekable() || !inner->size())
    throw usage_error("--loop: " + inner->name() +
                      " cannot be played backward (a recording folder or a synth: scene can)");
  return std::make_unique<LoopSource>(std::move(inner), static_cast<std::size_t>(passes));
}

}  // namespace aoscan
