/// @file tracking_reference.h
/// @brief Test oracle of the tracking module: the plain single-threaded ICP normal equations that
/// icp_system() and icp_system_portable() are checked against.
#pragma once

#include "core/pose.h"
#include "fusion/tracking/icp.h"
#include "fusion/tracking/tracking_config.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// Plain single-threaded reference of icp_system(): the library's per-pixel association
/// (icp_detail::Associator::pixel(), so the same correspondences) summed in one running double
/// sum over all pixels.
IcpSystem icp_system_reference(const PointMaps& frame, const PointMaps& model,
                               const Pose& T_model_camera, const TrackingConfig& config,
                               int pixel_step = 1);

}  // namespace aoscan
