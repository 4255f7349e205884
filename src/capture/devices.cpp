/// @file devices.cpp
/// @brief list_devices() over all back-ends and the `auto` camera choice.
#include "capture/devices.h"

#include "capture/freenect_source.h"
#include "capture/openni2_source.h"
#include "capture/v4l2_source.h"

namespace aoscan {

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> found = list_openni2_devices();
  for (DeviceInfo& d : list_freenect_devices()) found.push_back(std::move(d));
  for (DeviceInfo& d : list_v4l2_devices()) found.push_back(std::move(d));
  return found;
}

std::string devices_searched() {
  return "tried OpenNI2 (its installed drivers), libfreenect (Kinect v1 over USB) and V4L2 "
         "(/dev/video* nodes with Z16 depth)";
}

std::unique_ptr<Source> open_first_camera() {
  const std::vector<DeviceInfo> found = list_devices();
  if (found.empty()) throw device_error("auto: no depth camera found (" + devices_searched() + ")");
  std::string failures;
  for (const DeviceInfo& d : found) {
    try {
      return open_source(d.uri);
    } catch (const Error& e) {
      failures += (failures.empty() ? "" : "; ") + std::string(e.what());
    }
  }
  throw device_error("auto: no camera could be opened: " + failures);
}

}  // namespace aoscan
