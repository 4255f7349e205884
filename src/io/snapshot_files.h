/// @file snapshot_files.h
/// @brief What `--snapshot` writes beside the views for tools that read the views back: the model
/// raycast's depth, so that a view's pixels can be placed in the world (aoscan-eval stability).
#pragma once

namespace aoscan {

/// `DIR/raycast_depth_<frame, 6 digits>.png`: the depth along the optical axis of the model
/// surface the views show, at the raycast's resolution (the views enlarge it by pixel replication),
/// 16-bit grey in kRaycastDepthUnitsPerMetre units (0 = no surface, at most 65535 units).
inline constexpr const char* kRaycastDepthView = "raycast_depth";
/// TUM's depth unit: 5000 per metre (0.2 mm).
inline constexpr double kRaycastDepthUnitsPerMetre = 5000.0;

}  // namespace aoscan
