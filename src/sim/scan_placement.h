/// @file scan_placement.h
/// @brief Where the scanners of a synthetic scan set stand: the sunflower-spiral rule over an
/// analytic scene's free floor, the ranges the simulated scanners measure, and each scan's name
/// and noise key. aoscan-scanset writes its sets by this rule and the MVAO quality benchmark
/// renders its sets by it, so a benchmark row can be written to files and run through
/// `aoscan scans`.
#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "core/pose.h"

namespace aoscan {

/// Ranges the simulated scanners measure (m): a laser scanner, and a depth camera.
inline constexpr double kLaserScanMinRangeM = 0.1, kLaserScanMaxRangeM = 100.0;
inline constexpr double kDepthScanMinRangeM = 0.1, kDepthScanMaxRangeM = 10.0;
/// A scanner of the spiral stands at least this far from every surface of its scene (m).
inline constexpr double kScannerClearanceM = 0.3;

/// Where the scanners of a scene stand: an ellipse inscribed in a rectangle of free floor at one
/// height, and the point the scanners face (world frame, metres).
struct ScannerPlacement {
  Eigen::Vector2d min_xy;
  Eigen::Vector2d max_xy;
  double z = 0.0;
  Eigen::Vector3d target;
};

/// The placement of a built-in scene: room [0.6, 3.4]^2 at 1.5 m facing (2, 2, 0.5); corner
/// [0.8, 3.2]^2 at 1.5 m facing (1, 1, 0.5); plane x in [-2, 2], y in [-3.5, -1.5] at 0 m facing
/// the origin. Throws usage_error naming the scene otherwise.
ScannerPlacement scanner_placement(const std::string& scene);

/// Scan k of n (0 <= k < n): on the sunflower (Vogel) spiral filling the placement's ellipse,
/// radius sqrt((k + 0.5) / n) of the half-axes and azimuth k times the golden angle, so any number
/// of scans spreads evenly and every scan sees the middle of the scene that its neighbours see.
/// Equirectangular scanners (`pinhole` false) stand upright (z up) with their x axis facing the
/// target's direction; pinhole cameras (x right, y down, z forward) look at the target with
/// their x axis level.
Pose spiral_scanner_pose(const ScannerPlacement& place, int k, int n, bool pinhole);

/// The name of scan k of n: scan-001, scan-002, ... (more digits for more than 999 scans).
std::string spiral_scan_name(int k, int n);

/// The noise key of scan k of a set with `seed` (splitmix64 of both).
std::uint64_t spiral_scan_seed(std::uint64_t seed, int k);

}  // namespace aoscan
