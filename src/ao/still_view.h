/// @file still_view.h
/// @brief Down-weighting the repeated views of a camera that stands still (Sabbadin et al. 2016
/// Sec. 8): ten seconds of one view must not outvote the other views in the MVAO grid.
#pragma once

#include <cstdint>
#include <optional>

#include "ao/ao_config.h"
#include "core/pose.h"

namespace aoscan {

/// The factor of a frame's MVAO weights. The first frame is an anchor view; a frame within
/// config.still_view_distance_m of the anchor's position and config.still_view_angle_deg of its
/// viewing direction (the angle between the optical axes) repeats it, and the k-th such frame gets
/// config.still_view_decay^k (k = 1, 2, ...); the first frame beyond either threshold becomes the
/// new anchor (factor 1). So however long the camera stands still, its repeats add at most
/// decay / (1 - decay) views' weight to the anchor's. decay 1 (the default) is off: every factor is
/// 1. Not thread-safe: one caller (the mvao stage).
class StillViewWeight {
 public:
  explicit StillViewWeight(const AoConfig& config);

  /// The factor of the frame seen from `T_world_camera` (frames in order).
  float next(const Pose& T_world_camera);
  /// Forgets the anchor (the grid was cleared): the next frame is an anchor.
  void reset() { anchor_.reset(); }
  /// Frames since the anchor that repeated it (0 right after a new anchor).
  std::uint32_t repeats() const { return repeats_; }

 private:
  double decay_, distance_m_, min_cos_;
  std::optional<Pose> anchor_;
  std::uint32_t repeats_ = 0;
  float factor_ = 1.0f;  ///< decay_^repeats_
};

}  // namespace aoscan
