/// @file v4l2_source.h
/// @brief UVC depth cameras through V4L2: Z16 format negotiation, mmap streaming, frame decoding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "capture/devices.h"
#include "capture/source.h"
#include "core/image.h"
#include "core/status.h"

namespace aoscan {

/// Decodes one V4L2 Z16 buffer: `height` rows of `width` little-endian 16-bit depths, each row
/// starting `bytes_per_line` bytes after the previous one (>= 2 * width; padding is skipped).
/// `bytes_used` is what the driver filled. Resizes `out` to width x height (no allocation when the
/// size is unchanged). Returns corrupt_frame naming `origin` when the buffer is too short or the
/// geometry is impossible; never throws.
Status decode_z16(const std::uint8_t* data, std::size_t bytes_used, int width, int height,
                  int bytes_per_line, Image<std::uint16_t>& out, const std::string& origin);

/// What `v4l2:/dev/videoN[?colour=/dev/videoM]` asks for.
struct V4l2Uri {
  std::string depth_node;   ///< the Z16 depth node
  std::string colour_node;  ///< the colour node beside it ("" = none)
};

/// Parses a V4L2 camera URI. Throws usage_error naming the culprit.
V4l2Uri parse_v4l2_uri(const std::string& uri);

/// Opens `v4l2:/dev/videoN` as a live Source: negotiates Z16 (VIDIOC_S_FMT, 640x480 preferred,
/// whatever the driver settles on is used), asks for 30 Hz, streams through 4 mmap buffers.
/// Depth is taken as millimetres (depth_scale 1000, the UVC depth cameras' default); intrinsics
/// are nominal (fx = fy = 525 * width / 640, centred). Timestamps are the driver's buffer times
/// (s). A read returns device_lost when the node fails (unplug) or gives no frame for 2 s, and
/// corrupt_frame for a buffer the driver flags as broken or that is too short.
/// Throws device_error naming the node for a missing node, a node that is not a V4L2 capture
/// device (e.g. /dev/null), no Z16 format, a busy device, or any streaming set-up failure.
/// `v4l2:/dev/videoN?colour=/dev/videoM` adds the colour node M of the same camera: RGB24
/// (RGB3), YUYV or MJPEG (in that order of preference), the depth's size asked for, 30 Hz;
/// opened and configured on open (a bad node is a device_error naming it), streamed from the
/// first read only when colour is wanted (want_colour). Each depth frame is paired with the colour
/// frame nearest in time within 20 ms (both nodes' buffer times; it waits at most 40 ms for a
/// nearer one); a broken or undecodable colour frame, one of another size, or a colour node that
/// stops is a counted colour skip, never a lost depth frame. The colour camera is nominal: the
/// colour frames' size, fx = fy = 525 * width / 640, centred, at the depth camera (`--camera FILE`
/// gives a calibrated one).
std::unique_ptr<Source> open_v4l2_source(const std::string& uri);

/// V4L2 capture nodes under /dev that offer Z16 depth (`v4l2:/dev/videoN`).
std::vector<DeviceInfo> list_v4l2_devices();

}  // namespace aoscan
