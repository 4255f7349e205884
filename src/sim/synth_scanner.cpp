/// @file synth_scanner.cpp
/// @brief Range maps of analytic scenes from scanner poses.
#include "sim/synth_scanner.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/status.h"
#include "sim/counter_rng.h"

namespace aoscan {

void render_scan(const AnalyticScene& scene, const ScanCamera& camera, const Pose& T_world_scanner,
                 double min_range_m, double max_range_m, const ScannerNoise& noise, RangeMap& map) {
  if (!camera.valid()) throw usage_error(map.name + ": the scanner's camera is not usable");
  map.camera = camera;
  map.T_world_scanner = T_world_scanner;
  map.points.resize(camera.width, camera.height, Eigen::Vector3f::Zero());
  map.normals.resize(camera.width, camera.height, Eigen::Vector3f::Zero());
  const Eigen::Matrix3d& R = T_world_scanner.rotation();
  const Eigen::Matrix3d R_scanner_world = R.transpose();
  const tbb::blocked_range<int> all_rows(0, camera.height);
  tbb::parallel_for(all_rows, [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < camera.width; ++x) {
        map.points(x, y).setZero();
        map.normals(x, y).setZero();
        const Eigen::Vector3d d_scanner = camera.pixel_ray(x, y);
        Ray ray;
        ray.origin = T_world_scanner.translation();
        ray.direction = R * d_scanner;
        Hit hit;
        if (!scene.intersect(ray, min_range_m, max_range_m, &hit)) continue;
        double t = hit.t;
        if (noise.sigma_m > 0.0 || noise.sigma_per_m > 0.0) {
          CounterRng rng(noise.seed, 0x5ca22e7, static_cast<std::uint64_t>(y) * camera.width + x);
          double n0 = 0.0, n1 = 0.0;
          rng.normal_pair(&n0, &n1);
          t += (noise.sigma_m + noise.sigma_per_m * hit.t) * n0;
        }
        // Depth along the ray for pinhole maps too: the point is where the ray meets the surface.
        map.points(x, y) = (d_scanner * t).cast<float>();
        Eigen::Vector3d n = R_scanner_world * hit.normal;
        if (n.dot(d_scanner) > 0.0) n = -n;  // face the scanner
        map.normals(x, y) = n.cast<float>();
      }
  });
}

}  // namespace aoscan
