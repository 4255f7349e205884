/// @file openni2_source.h
/// @brief OpenNI2 cameras (PrimeSense, Asus Xtion, Orbbec, ...) and `.oni` recordings.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "capture/devices.h"
#include "capture/source.h"

namespace aoscan {

/// Opens `openni2` (the first device OpenNI2 offers) or `openni2:URI` (a device URI as
/// list_openni2_devices() prints it) as a live Source. Picks the depth mode closest to 640x480 at
/// 30 Hz in 1 mm or 100 um units (depth_scale 1000 or 10000), turns mirroring off where the
/// driver allows it, and stamps frames with the device's timestamps (s). Intrinsics come from the
/// stream's fields of view (525 * width / 640 when the driver reports none). A read returns
/// device_lost when no frame arrives for 2 s (unplug).
/// Colour, when the device has a colour sensor with an RGB888 mode (the one nearest to the depth
/// size @ 30 Hz): where the device supports IMAGE_REGISTRATION_DEPTH_TO_COLOR it is turned on at
/// open (also with colour off: the depth's geometry does not depend on fusion.colour) and the
/// colour camera is registered (the same view, scaled when the colour size differs); otherwise
/// the colour camera is nominal: its stream's field of view, 25 mm along the depth camera's +x
/// axis, no rotation (`--camera FILE` gives a calibrated one). The colour stream is started
/// before the first read only when colour is wanted (want_colour). Each depth frame is paired
/// with the colour frame nearest in device time within 20 ms (ColourPairer; it waits at most
/// 40 ms for a nearer one); a depth frame without one has colour_error set, and the depth goes on
/// when the colour stream stops.
/// Throws device_error when OpenNI2 cannot start, the device cannot be opened (the message carries
/// OpenNI2's reason), it has no depth sensor or mode, or it is already open in this process.
std::unique_ptr<Source> open_openni2_source(const std::string& uri);

/// Opens an OpenNI2 recording (`FILE.oni`) through OpenNI2's own playback as a replay Source:
/// manual speed (-1: every frame, as fast as the reader asks), no repeat, size() = the depth
/// stream's frame count; its colour stream, when it has one, paired with the depth as for a
/// device. Throws input_error naming the file when it is missing, not a recording
/// OpenNI2 can open, or holds no depth stream. A frame that does not arrive within 2 s is
/// bad_input naming the file and frame.
std::unique_ptr<Source> open_oni_file(const std::string& path);

/// The devices OpenNI2's drivers see (`openni2:URI`); empty when OpenNI2 cannot start.
std::vector<DeviceInfo> list_openni2_devices();

}  // namespace aoscan
