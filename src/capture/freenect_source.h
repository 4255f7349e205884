/// @file freenect_source.h
/// @brief Kinect v1 through libfreenect (or fakenect, its dump-replaying stand-in).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "capture/devices.h"
#include "capture/source.h"

namespace aoscan {

/// What `freenect[:INDEX][?depth=raw|mm]` asks for.
struct FreenectUri {
  int index = 0;          ///< device index as libfreenect counts them
  bool depth_mm = false;  ///< the driver's FREENECT_DEPTH_MM mode instead of raw 11-bit disparity
};

/// Parses `freenect`, `freenect:1`, `freenect:0?depth=mm`. Throws usage_error naming the culprit.
FreenectUri parse_freenect_uri(const std::string& uri);

/// Opens a Kinect v1 as a live Source of 640x480 depth in millimetres (depth_scale 1000):
/// raw 11-bit disparity converted by kinect_raw_to_mm (default), or the driver's own mm mode.
/// Timestamps: the device's 60 MHz clock, unwrapped, in seconds; DepthFrame::arrived_at is the
/// host time of libfreenect's depth callback. A read that sees libfreenect fail
/// (unplug) or no frame for 2 s returns device_lost. Throws device_error for no such device, a
/// device that cannot be opened (busy, permissions), or one already open in this process; under
/// fakenect, also when FAKENECT_PATH does not name a dump (fakenect would exit the process).
std::unique_ptr<Source> open_freenect_source(const std::string& uri);

/// The Kinects libfreenect sees (`freenect:N`); empty when libfreenect cannot start.
std::vector<DeviceInfo> list_freenect_devices();

}  // namespace aoscan
