/// @file scan_placement.cpp
/// @brief The sunflower-spiral placement of synthetic scanners.
#include "sim/scan_placement.h"

#include <algorithm>
#include <cmath>

#include "core/status.h"

namespace aoscan {
namespace {

/// The golden angle (radians): successive scans of the spiral turn by it.
constexpr double kGoldenAngle = 2.39996322972865332;

}  // namespace

ScannerPlacement scanner_placement(const std::string& scene) {
  if (scene == "room") return {{0.6, 0.6}, {3.4, 3.4}, 1.5, {2.0, 2.0, 0.5}};
  if (scene == "corner") return {{0.8, 0.8}, {3.2, 3.2}, 1.5, {1.0, 1.0, 0.5}};
  if (scene == "plane") return {{-2.0, -3.5}, {2.0, -1.5}, 0.0, {0.0, 0.0, 0.0}};
  throw usage_error("no scanner placement for scene '" + scene + "'");
}

Pose spiral_scanner_pose(const ScannerPlacement& place, int k, int n, bool pinhole) {
  const Eigen::Vector2d centre = 0.5 * (place.min_xy + place.max_xy);
  const Eigen::Vector2d half = 0.5 * (place.max_xy - place.min_xy);
  const double r = std::sqrt((k + 0.5) / n);
  const double a = k * kGoldenAngle;
  const Eigen::Vector3d position(centre.x() + r * half.x() * std::cos(a),
                                 centre.y() + r * half.y() * std::sin(a), place.z);
  Eigen::Vector3d forward = place.target - position;
  if (!pinhole) {
    forward.z() = 0.0;
    if (forward.norm() < 1e-9) forward = Eigen::Vector3d::UnitX();
    forward.normalize();
    Eigen::Matrix3d R;
    R.col(0) = forward;
    R.col(2) = Eigen::Vector3d::UnitZ();
    R.col(1) = R.col(2).cross(R.col(0));
    return Pose(R, position);
  }
  forward.normalize();
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());  // image x, level
  if (right.norm() < 1e-6) right = Eigen::Vector3d::UnitX();        // looking straight down/up
  right.normalize();
  Eigen::Matrix3d R;
  R.col(0) = right;
  R.col(2) = forward;
  R.col(1) = forward.cross(right);  // image y: down
  return Pose(R, position);
}

std::string spiral_scan_name(int k, int n) {
  const int digits = std::max(3, static_cast<int>(std::to_string(n).size()));
  std::string number = std::to_string(k + 1);
  return "scan-" + std::string(static_cast<std::size_t>(digits) - number.size(), '0') + number;
}

std::uint64_t spiral_scan_seed(std::uint64_t seed, int k) {
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ULL + static_cast<std::uint64_t>(k) + 1;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace aoscan
