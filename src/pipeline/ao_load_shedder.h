/// @file ao_load_shedder.h
/// @brief Live load shedding of the SSAO stage: when a live chain drops frames in front of
/// tracking, SSAO runs on every 3rd, 5th, ... tracked frame until the drops stop.
#pragma once

#include <algorithm>
#include <cstddef>

namespace aoscan {

/// Decides, frame by frame, whether the ssao stage computes a tracked frame's SSAO. Live (a camera
/// or `--realtime`), frames are dropped in front of the track stage when the chain cannot keep up
/// with the camera; SSAO shares the two cores with tracking, every dropped frame makes the next ICP
/// step longer, and the MVAO grid still gathers AO from the views that are shaded (what fewer
/// views cost the AO under load is not measured; see BENCHMARKS.md). Each new drop (the run's count
/// carried by the frames grows) widens the interval by 2 up to the maximum; kCalmFrames frames
/// without a drop narrow it by 2. The intervals are odd (1, 3, 5, ...): the SSAO pattern's pixel of
/// each 2x2 block follows the frame sequence modulo 4, which an odd step walks through all four
/// (while no frame is dropped between). Without drops (every replay that is not paced) the interval
/// stays 1 and nothing changes. One user: the ssao stage's thread.
class AoLoadShedder {
 public:
  /// Frames without a new drop before the interval narrows (a second at 30 Hz).
  static constexpr int kCalmFrames = 30;

  /// `max_interval` (>= 1): the widest interval; an even value counts as the odd one below it.
  explicit AoLoadShedder(int max_interval)
      : max_(std::max(1, max_interval - (1 - max_interval % 2))) {}

  /// Called for every tracked frame in chain order with the drops counted when it was captured
  /// (FrameWork::frames_dropped_before); true: compute this frame's SSAO.
  bool take(std::size_t drops_before) {
    if (drops_before > drops_) {
      interval_ = std::min(interval_ + 2, max_);
      calm_ = 0;
      drops_ = drops_before;
    } else if (interval_ > 1 && ++calm_ >= kCalmFrames) {
      interval_ -= 2;
      calm_ = 0;
    }
    if (phase_ >= interval_) phase_ = 0;
    const bool take = phase_ == 0;
    phase_ = (phase_ + 1) % interval_;
    if (!take) ++skipped_;
    return take;
  }

  int interval() const { return interval_; }
  /// Frames whose SSAO was skipped so far.
  std::size_t skipped() const { return skipped_; }

 private:
  int max_;
  int interval_ = 1;
  int calm_ = 0;
  int phase_ = 0;
  std::size_t drops_ = 0;
  std::size_t skipped_ = 0;
};

}  // namespace aoscan
