/// @file camera_file.h
/// @brief `--camera FILE`: a camera.json that replaces a source's nominal calibration (a live
/// camera's depth intrinsics, depth units and colour camera).
#pragma once

#include <memory>
#include <string>

#include "capture/source.h"
#include "io/camera_json.h"

namespace aoscan {

/// Reads `path` (camera.json format, see read_camera_json()) for `--camera`. Throws usage_error
/// (exit 2: a file given on the command line, like --config) with the one-line reason naming the
/// file. Read before any camera is opened.
CameraInfo read_camera_file(const std::string& path);

/// Wraps `inner` so that its frames carry `camera` (from read_camera_file(`path`)):
/// - intrinsics() and every frame's intrinsics are the file's; a file without width/height takes
///   the source's size; depth_scale() and the frames' depth_scale are the file's (a warning when
///   it differs from the source's own);
/// - when the file has a `colour` object and the source has colour, the frames' colour camera is
///   the file's (`registered`: registered to the file's depth intrinsics); a colour image of
///   another size than that camera is dropped as a colour skip (DepthFrame::colour_error); a
///   file without `colour` keeps the source's colour camera; a file with `colour` for a source
///   without colour is a warning;
/// - calibration_origin() (and colour_origin() when the file's colour is used) names the file.
/// Throws usage_error naming the file when its width/height are not the source's or its
/// intrinsics are implausible. A frame whose depth is not the file's size is a corrupt frame.
std::unique_ptr<Source> with_camera_file(std::unique_ptr<Source> inner, const CameraInfo& camera,
                                         const std::string& path);

}  // namespace aoscan
