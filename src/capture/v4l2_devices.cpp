/// @file v4l2_devices.cpp
/// @brief Lists V4L2 capture nodes that offer a 16-bit depth format (UVC depth cameras).
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "capture/devices.h"

namespace aoscan {
namespace {

/// Depth pixel formats we can decode: Z16 (RealSense and other UVC depth cameras).
bool is_depth_format(std::uint32_t fourcc) { return fourcc == v4l2_fourcc('Z', '1', '6', ' '); }

std::vector<DeviceInfo> list_v4l2_devices() {
  std::vector<std::string> nodes;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("video", 0) == 0) nodes.push_back(entry.path().string());
  }
  std::sort(nodes.begin(), nodes.end());
  std::vector<DeviceInfo> found;
  for (const std::string& node : nodes) {
    const int fd = ::open(node.c_str(), O_RDWR | O_NONBLOCK);
    if (fd < 0) continue;
    v4l2_capability cap{};
    if (::ioctl(fd, VIDIOC_QUERYCAP, &cap) == 0 && (cap.device_caps & V4L2_CAP_VIDEO_CAPTURE)) {
      v4l2_fmtdesc fmt{};
      fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      for (fmt.index = 0; ::ioctl(fd, VIDIOC_ENUM_FMT, &fmt) == 0; ++fmt.index) {
        if (is_depth_format(fmt.pixelformat)) {
          found.push_back({"v4l2:" + node, std::string(reinterpret_cast<const char*>(cap.card)) +
                                               " (" + reinterpret_cast<const char*>(cap.driver) +
                                               ", Z16 depth)"});
          break;
        }
      }
    }
    ::close(fd);
  }
  return found;
}

}  // namespace

std::vector<DeviceInfo> list_devices() { return list_v4l2_devices(); }

std::string devices_searched() { return "looked at V4L2 /dev/video* nodes for Z16 depth"; }

}  // namespace aoscan
