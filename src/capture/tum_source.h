/// @file tum_source.h
/// @brief A recording folder in TUM RGB-D layout (depth.txt + 16-bit depth PNGs, optional
/// camera.json and groundtruth.txt) as a Source.
#pragma once

#include <memory>
#include <string>

#include "capture/source.h"

namespace aoscan {

/// Ground-truth poses are attached to a frame when their timestamp is this close (seconds).
inline constexpr double kGroundTruthMaxDtS = 0.02;

/// Opens `folder` as a TUM RGB-D recording:
/// - depth.txt lists `timestamp path` (paths relative to the folder); frames are read in its order,
///   DepthFrame::sequence is the index in that list, origin the PNG path;
/// - calibration from camera.json when present, else default_camera_for_folder(); the expected
///   frame size is camera.json's width/height, else the size of the first frame that decodes;
/// - groundtruth.txt (optional) gives DepthFrame::T_world_camera_gt by nearest timestamp within
///   kGroundTruthMaxDtS.
/// read() returns corrupt_frame ("FOLDER/depth/x.png (frame 12): truncated PNG") for a missing,
/// truncated, non-16-bit-grey PNG or one of another size, and the stream goes on.
/// Throws input_error: "FOLDER: no such folder"; depth.txt missing, unreadable, garbled
/// (FILE:LINE) or listing no frame; a bad camera.json or groundtruth.txt.
std::unique_ptr<Source> open_tum_folder(const std::string& folder);

}  // namespace aoscan
