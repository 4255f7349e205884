/// @file freenect_source.h
/// @brief Kinect v1 through libfreenect (or fakenect, its dump-replaying stand-in).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "capture/devices.h"
#include "capture/source.h"

namespace aoscan {

/// The depth a Kinect delivers.
enum class FreenectDepth {
  kRaw,         ///< raw 11-bit disparity, converted by kinect_raw_to_mm (the default)
  kMm,          ///< the driver's FREENECT_DEPTH_MM: millimetres, in the depth camera's pixels
  kRegistered,  ///< the driver's FREENECT_DEPTH_REGISTERED: millimetres resampled onto the RGB
                ///< camera's pixels (libfreenect's registration from the device's own tables)
};

/// What `freenect[:INDEX][?depth=raw|mm|registered]` asks for.
struct FreenectUri {
  int index = 0;  ///< device index as libfreenect counts them
  FreenectDepth depth = FreenectDepth::kRaw;
};

/// Parses `freenect`, `freenect:1`, `freenect:0?depth=mm`, `freenect?depth=registered`. Throws
/// usage_error naming the culprit.
FreenectUri parse_freenect_uri(const std::string& uri);

/// Opens a Kinect v1 as a live Source of 640x480 depth in millimetres (depth_scale 1000):
/// raw 11-bit disparity converted by kinect_raw_to_mm (default), or the driver's own mm mode
/// (both in the depth camera's pixels: fx = fy = 585), or the driver's registered mode (depth
/// resampled onto the RGB camera's pixels: the RGB camera's intrinsics, fx = fy = 525, and a
/// registered colour camera).
/// Colour (unless want_colour(false), when no RGB stream is started): the 640x480 RGB stream,
/// each depth frame paired with the RGB frame nearest in time within 20 ms (ColourPairer; a depth
/// frame waits at most 40 ms for a nearer one). Without registration the colour camera is the
/// nominal Kinect v1 RGB camera: fx = fy = 525, centred, 25 mm along the depth camera's +x axis
/// (`--camera FILE` gives a calibrated one). Under fakenect, the dump's `r-*.ppm` frames; a dump
/// without them is a depth-only camera.
/// Timestamps: the device's 60 MHz clock, unwrapped, in seconds; DepthFrame::arrived_at is the
/// host time of libfreenect's depth callback. A read that sees libfreenect fail
/// (unplug) or no frame for 2 s returns device_lost. Throws device_error for no such device, a
/// device that cannot be opened (busy, permissions), or one already open in this process; under
/// fakenect, also when FAKENECT_PATH does not name a dump (fakenect would exit the process).
std::unique_ptr<Source> open_freenect_source(const std::string& uri);

/// The Kinects libfreenect sees (`freenect:N`); empty when libfreenect cannot start.
std::vector<DeviceInfo> list_freenect_devices();

}  // namespace aoscan
