/// @file synth_scanner.h
/// @brief The synthetic scanner: range maps of an analytic scene from chosen scanner poses, with
/// exact points and normals or a laser-scanner noise model, as the ground truth of the
/// multi-scan MVAO (pinhole depth cameras and equirectangular 360-degree laser scans).
#pragma once

#include <cstdint>

#include "core/pose.h"
#include "geometry/range_map.h"
#include "sim/synth_scene.h"

namespace aoscan {

/// Range noise of a laser scanner: a Gaussian error along the ray of sigma_m + sigma_per_m times
/// the range (time-of-flight scanners quote a few millimetres). 0 gives exact points.
struct ScannerNoise {
  double sigma_m = 0.0;
  double sigma_per_m = 0.0;
  std::uint64_t seed = 1;  ///< with the pixel index, keys each pixel's error
};

/// Renders `scene` (world frame) as seen by a scanner with `camera` at T_world_scanner into
/// `map`: one ray per pixel centre (ScanCamera::pixel_ray()); the nearest hit within
/// [min_range_m, max_range_m] of the scanner gives the pixel's point (scanner frame; moved along
/// the ray by the noise) and the surface's exact normal (scanner frame, facing the scanner).
/// Pixels without a hit stay empty. Rows run in parallel; every pixel is a pure function of its
/// inputs, so any thread count gives the same map. `map.name` is kept.
void render_scan(const AnalyticScene& scene, const ScanCamera& camera, const Pose& T_world_scanner,
                 double min_range_m, double max_range_m, const ScannerNoise& noise, RangeMap& map);

}  // namespace aoscan
