/// @file camera_json.h
/// @brief camera.json of a recording folder (calibration and depth units) and the contract's
/// defaults for folders without one.
#pragma once

#include <optional>
#include <string>

#include "core/colour.h"
#include "core/intrinsics.h"

namespace aoscan {

/// Calibration of a depth stream as a recording folder stores it.
struct CameraInfo {
  Intrinsics intrinsics;     ///< pinhole intrinsics in pixels, with the image size
  double depth_scale = 0.0;  ///< raw depth units per metre
  bool size_given = false;   ///< true when the file gave `width` and `height`
  /// Where the calibration came from, for the log and stats.json: "camera.json", "the TUM
  /// freiburg1 calibration (folder name)", "the default calibration (no camera.json)".
  std::string origin;
  /// True for the generic default: nothing about this camera is known.
  bool is_default = false;
  /// The colour camera, when the file has a `colour` object.
  std::optional<ColourCamera> colour;
};

/// Reads `{ "fx", "fy", "cx", "cy", "depth_scale" [, "width", "height"] }` (pixels; raw units per
/// metre). Missing `width`/`height` take `default_width`/`default_height` (size_given = false);
/// the two must be given together. Throws input_error, one line naming the file and the key, on an
/// unreadable file, invalid JSON, a missing key, a non-number, a non-finite value,
/// fx/fy/depth_scale
/// <= 0, or a width/height that is not a positive integer.
///
/// An optional `colour` object describes the colour camera: either `{ "registered": true }`
/// (colour already resampled onto the depth pixels) or `{ "width", "height", "fx", "fy", "cx",
/// "cy", "depth_to_colour" }` with `depth_to_colour` the 12 numbers of the 3x4 row-major matrix
/// [R | t] that maps a depth-camera point (metres) into the colour camera's frame. R must be a
/// rotation to within 1e-3 (it is then made exactly orthonormal); errors name `colour.KEY`.
CameraInfo read_camera_json(const std::string& path, int default_width, int default_height);

/// Writes camera.json with width, height, fx, fy, cx, cy and depth_scale (and the `colour` object
/// when `colour` is given) in shortest round-trip precision (reading it back gives identical
/// doubles). Throws usage_error for invalid intrinsics or scale and Error (exit code 1) when the
/// file cannot be written.
void write_camera_json(const std::string& path, const Intrinsics& intrinsics, double depth_scale,
                       const ColourCamera* colour = nullptr);

/// The contract's calibration for a TUM-layout folder without camera.json, chosen by the folder's
/// own name: TUM freiburg1/2/3 intrinsics when the name contains freiburg1/2/3, else fx = fy = 525,
/// cx = 319.5, cy = 239.5; always 640x480 and depth_scale 5000 (size_given = false).
CameraInfo default_camera_for_folder(const std::string& folder);

}  // namespace aoscan
