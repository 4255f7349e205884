/// @file still_view.cpp
/// @brief Repeated views of a still camera.
#include "ao/still_view.h"

#include <cmath>

namespace aoscan {

StillViewWeight::StillViewWeight(const AoConfig& config)
    : decay_(config.still_view_decay),
      distance_m_(config.still_view_distance_m),
      min_cos_(std::cos(config.still_view_angle_deg * M_PI / 180.0)) {}

float StillViewWeight::next(const Pose& T_world_camera) {
  if (decay_ >= 1.0) return 1.0f;
  const bool repeat =
      anchor_ &&
      (T_world_camera.translation() - anchor_->translation()).norm() <= distance_m_ &&
      T_world_camera.rotation().col(2).dot(anchor_->rotation().col(2)) >= min_cos_;
  if (!repeat) {
    anchor_ = T_world_camera;
    repeats_ = 0;
    factor_ = 1.0f;
    return factor_;
  }
  ++repeats_;
  factor_ = static_cast<float>(factor_ * decay_);
  return factor_;
}

}  // namespace aoscan
