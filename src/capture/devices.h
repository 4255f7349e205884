/// @file devices.h
/// @brief Enumeration of the depth cameras the capture back-ends can see, and `auto` selection.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "capture/source.h"

namespace aoscan {

struct DeviceInfo {
  std::string uri;          ///< what `scan --device` accepts, e.g. v4l2:/dev/video2
  std::string description;  ///< model / driver and depth formats
};

/// Every depth camera found by OpenNI2, libfreenect and V4L2, in that order; an empty list is not
/// an error.
std::vector<DeviceInfo> list_devices();

/// What list_devices() looked at, for the "nothing found" message.
std::string devices_searched();

/// `auto`: opens the first camera of list_devices() that opens. Throws device_error that lists
/// what was tried (and why each candidate failed) when none does.
std::unique_ptr<Source> open_first_camera();

}  // namespace aoscan
