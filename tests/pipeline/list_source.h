/// @file list_source.h
/// @brief A Source serving a fixed list of frames (copies of corner frames, possibly edited), for
/// the pipeline tests that run whole sessions on made-up takes.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "capture/source.h"
#include "support/synth_frames.h"

namespace aoscan::test {

/// Serves a fixed list of frames (copies of corner frames, possibly edited).
class ListSource : public Source {
 public:
  explicit ListSource(std::vector<DepthFrame> frames) : frames_(std::move(frames)) {}
  Status read(DepthFrame& frame) override {
    if (next_ >= frames_.size()) return Status::end_of_stream();
    frame = frames_[next_++];
    return Status::ok();
  }
  std::string name() const override { return "list"; }
  const Intrinsics& intrinsics() const override { return frames_.front().intrinsics; }
  double depth_scale() const override { return kSynthDepthScale; }
  std::optional<std::size_t> size() const override { return frames_.size(); }

 private:
  std::vector<DepthFrame> frames_;
  std::size_t next_ = 0;
};

/// Corner frames `first` .. `last` - 1 (320x240, exact depth), then `then_first` ..
/// `then_last` - 1.
inline std::vector<DepthFrame> frames(int first, int last, int then_first = 0,
                                      int then_last = 0) {
  std::vector<DepthFrame> out;
  for (int i = first; i < last; ++i) out.push_back(test::corner_frame(i));
  for (int i = then_first; i < then_last; ++i) out.push_back(test::corner_frame(i));
  return out;
}

}  // namespace aoscan::test
