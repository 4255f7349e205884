/// @file devices.h
/// @brief Enumeration of the depth cameras the capture back-ends can see.
#pragma once

#include <string>
#include <vector>

namespace aoscan {

struct DeviceInfo {
  std::string uri;          ///< what `scan --device` accepts, e.g. v4l2:/dev/video2
  std::string description;  ///< model / driver and depth formats
};

/// Every depth camera found; an empty list is not an error.
std::vector<DeviceInfo> list_devices();

/// What list_devices() looked at, for the "nothing found" message.
std::string devices_searched();

}  // namespace aoscan
