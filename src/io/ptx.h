/// @file ptx.h
/// @brief PTX, the ASCII exchange format of terrestrial laser scanners: one or more structured
/// scans per file, each a header (grid size, scanner position and axes, registration matrix)
/// followed by its grid of points in the scanner's frame.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/pose.h"

namespace aoscan {

/// One scan of a PTX file.
struct PtxScan {
  int columns = 0;
  int rows = 0;
  /// The registration: scanner frame to world (the header's 4 x 4 matrix, whose last row PTX
  /// writes as the translation).
  Pose T_world_scanner;
  /// The points that returned (x y z not all zero), scanner frame, in file order; a point with a
  /// coordinate that is nan or infinite is kept as read (rasterize_points() skips and counts it).
  std::vector<Eigen::Vector3f> points;
  long long missing = 0;  ///< grid cells without a return (0 0 0)
};

/// Reads every scan of the PTX file at `path`. A point line holds x y z and an intensity, and
/// optionally r g b (ignored). Throws input_error naming the file and line on a missing file, a
/// bad header (grid size not positive, a registration that is not a finite rigid transform), a
/// line that does not parse (nan and inf parse on a point's line only), or a file that ends
/// inside a scan's grid.
std::vector<PtxScan> read_ptx(const std::string& path);

/// The same, one scan at a time: `each` takes every scan as soon as it is read (the file's scans
/// need not fit in memory together). Returns the number of scans. A scan handed over is complete;
/// an error later in the file throws after it.
std::size_t read_ptx(const std::string& path, const std::function<void(PtxScan&&)>& each);

}  // namespace aoscan
