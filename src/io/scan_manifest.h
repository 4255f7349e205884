/// @file scan_manifest.h
/// @brief The scan manifest of `aoscan scans`: a JSON or YAML file listing registered scans, each
/// a depth image with its intrinsics or a point cloud with its scanner position, and its pose.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/intrinsics.h"
#include "core/pose.h"

namespace aoscan {

/// One scan as the manifest describes it; paths are resolved against the manifest's folder.
struct ScanEntry {
  enum class Kind {
    kDepthImage,  ///< a 16-bit depth PNG seen by a pinhole camera
    kPointCloud,  ///< a PLY point cloud (with or without normals) from a laser scanner
  };
  std::string name;  ///< unique within the set; the file's stem when not given
  Kind kind = Kind::kDepthImage;
  std::string path;          ///< the depth PNG or the PLY
  Intrinsics intrinsics;     ///< depth images: the camera (its size is the image's)
  double depth_scale = 0.0;  ///< depth images: raw units per metre
  /// The scan's registration: depth images, camera to world; point clouds, the cloud's own frame
  /// to world.
  Pose T_world_scan;
  /// Point clouds: the scanner's position in the cloud's frame (metres); the equirectangular map
  /// is centred there, z up.
  Eigen::Vector3d scanner = Eigen::Vector3d::Zero();
};

/// Reads a manifest:
///
///     scans:
///       - name: kitchen-1                 # optional
///         depth: frames/0001.png          # a 16-bit PNG ...
///         camera: {fx: 525, fy: 525, cx: 319.5, cy: 239.5, depth_scale: 5000}
///         pose: [r00, r01, r02, tx, r10, ..., 0, 0, 0, 1]   # 4 x 4, row-major, or
///       - points: laser/scan2.ply         # ... or a PLY point cloud
///         scanner: [0.0, 0.0, 1.6]        # the scanner's position in the cloud's frame
///         pose: {t: [x, y, z], q: [qx, qy, qz, qw]}      # TUM order
///
/// JSON with the same keys works too. `pose` is optional (identity). Throws input_error, one line
/// naming the manifest and the scan, on a missing or unreadable file, a syntax error, a scan with
/// both or neither of `depth` and `points`, a depth scan without a valid camera, a pose that is not
/// a finite rigid transform, or two scans with one name; usage_error on an unknown key.
std::vector<ScanEntry> read_scan_manifest(const std::string& path);

}  // namespace aoscan
