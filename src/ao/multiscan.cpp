/// @file multiscan.cpp
/// @brief Multi-view AO integration of registered scans (Eq. 6-12).
#include "ao/multiscan.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Geometry>

#include "ao/ssao.h"
#include "core/status.h"

namespace aoscan {
namespace {

/// World bounding box of a scan's points.
Eigen::AlignedBox3f world_box(const RangeMap& map) {
  Eigen::AlignedBox3f box;
  const Eigen::Matrix3f R = map.T_world_scanner.rotation().cast<float>();
  const Eigen::Vector3f t = map.T_world_scanner.translation().cast<float>();
  for (int y = 0; y < map.points.height(); ++y)
    for (int x = 0; x < map.points.width(); ++x)
      if (map.has_point(x, y)) box.extend(R * map.points(x, y) + t);
  return box;
}

/// Scan j seen from scan i: the rigid transform of scan i's points into scan j's frame, and
/// scanner i's position there.
struct PairFrame {
  int j = 0;
  Eigen::Matrix3f R;
  Eigen::Vector3f t;
  Eigen::Vector3f scanner_i;
};

/// The accumulated samples of one point.
struct Sum {
  double ao_w = 0.0;
  double w = 0.0;
  bool other_scan = false;
};

/// Adds the N x N samples of scan j around pixel (px, py) to `sum`.
void add_samples(const ScanAo& scan_j, const PairFrame& f, int px, int py, float rad_i,
                 const MultiScanParams& params, Sum& sum) {
  const RangeMap& map = scan_j.map;
  const int half = params.neighbourhood / 2;
  const bool wrap = map.camera.projection == ScanProjection::kEquirectangular;
  for (int dy = -half; dy <= half; ++dy)
    for (int dx = -half; dx <= half; ++dx) {
      int x = px + dx;
      const int y = py + dy;
      if (wrap) x = (x + map.camera.width) % map.camera.width;
      if (x < 0 || y < 0 || x >= map.camera.width || y >= map.camera.height) continue;
      if (!map.has_point(x, y)) continue;
      const Eigen::Vector3f& q = map.points(x, y);
      const Eigen::Vector3f& n = map.normals(x, y);
      if (!((f.scanner_i - q).dot(n) > 0.0f)) continue;  // not visible from scanner i
      float w = view_weight(q, n, params.d_min_m, params.d_max_m);
      if (params.border_weight) {
        const float alpha = rad_i / point_radius(map.camera, map.camera.depth(q));
        w *= std::min(scan_j.border_px(x, y) / (params.t_p_px * alpha), 1.0f);
      }
      if (!(w > 0.0f)) continue;
      sum.ao_w += static_cast<double>(w) * scan_j.ssao(x, y);
      sum.w += w;
    }
}

void check_scan(const ScanAo& s) {
  const int w = s.map.camera.width, h = s.map.camera.height;
  auto same = [&](int iw, int ih) { return iw == w && ih == h; };
  if (!same(s.map.points.width(), s.map.points.height()) ||
      !same(s.map.normals.width(), s.map.normals.height()) ||
      !same(s.ssao.width(), s.ssao.height()) || !same(s.border_px.width(), s.border_px.height()))
    throw usage_error(s.map.name + ": the scan's maps do not all have its camera's size");
}

}  // namespace

MultiScanStats integrate_scans(const std::vector<ScanAo>& scans, const MultiScanParams& params,
                               std::vector<Image<float>>& mvao) {
  if (params.neighbourhood < 1 || params.neighbourhood > 9 || params.neighbourhood % 2 == 0)
    throw usage_error("multi-scan AO: the neighbourhood must be 1, 3, 5, 7 or 9 (got " +
                      std::to_string(params.neighbourhood) + ")");
  for (const ScanAo& s : scans) check_scan(s);
  MultiScanStats stats;
  const int n = static_cast<int>(scans.size());
  std::vector<Eigen::AlignedBox3f> boxes(n);
  for (int i = 0; i < n; ++i) {
    boxes[i] = world_box(scans[i].map);
    stats.points += scans[i].map.count_points();
  }
  mvao.resize(n);
  std::vector<long long> shared(n, 0);
  for (int i = 0; i < n; ++i) {
    const RangeMap& map_i = scans[i].map;
    const Pose& T_i = map_i.T_world_scanner;
    std::vector<PairFrame> frames;
    for (int j = 0; j < n; ++j) {
      Eigen::AlignedBox3f grown = boxes[j];
      if (!grown.isEmpty()) {
        grown.min().array() -= params.pair_margin_m;
        grown.max().array() += params.pair_margin_m;
      }
      if (j != i && (boxes[i].isEmpty() || grown.isEmpty() || !grown.intersects(boxes[i]))) {
        ++stats.pairs_skipped;
        continue;
      }
      if (j != i) ++stats.pairs_tested;
      const Pose T_j_i = scans[j].map.T_world_scanner.inverse() * T_i;
      PairFrame f;
      f.j = j;
      f.R = T_j_i.rotation().cast<float>();
      f.t = T_j_i.translation().cast<float>();
      f.scanner_i = f.t;
      frames.push_back(f);
    }
    Image<float>& out = mvao[i];
    out.resize(map_i.camera.width, map_i.camera.height, 1.0f);
    std::vector<long long> shared_rows(map_i.camera.height, 0);
    tbb::parallel_for(
        tbb::blocked_range<int>(0, map_i.camera.height), [&](const tbb::blocked_range<int>& rows) {
          for (int y = rows.begin(); y < rows.end(); ++y)
            for (int x = 0; x < map_i.camera.width; ++x) {
              if (!map_i.has_point(x, y)) {
                out(x, y) = 1.0f;
                continue;
              }
              const Eigen::Vector3f& p = map_i.points(x, y);
              const float rad_i = point_radius(map_i.camera, map_i.camera.depth(p));
              Sum sum;
              for (const PairFrame& f : frames) {
                const ScanAo& scan_j = scans[f.j];
                const Eigen::Vector3f q = f.R * p + f.t;
                int px = 0, py = 0;
                if (!scan_j.map.camera.pixel_of(q, px, py) || !scan_j.map.has_point(px, py))
                  continue;
                const Eigen::Vector3f& p_ij = scan_j.map.points(px, py);
                const float t =
                    std::max(rad_i, point_radius(scan_j.map.camera, scan_j.map.camera.depth(p_ij)));
                if (!((q - p_ij).norm() < 2.0f * t)) continue;
                if (!((f.scanner_i - p_ij).dot(scan_j.map.normals(px, py)) > 0.0f)) continue;
                const double before = sum.w;
                add_samples(scan_j, f, px, py, rad_i, params, sum);
                if (f.j != i && sum.w > before) sum.other_scan = true;
              }
              out(x, y) = sum.w > 0.0 ? static_cast<float>(sum.ao_w / sum.w) : scans[i].ssao(x, y);
              shared_rows[y] += sum.other_scan ? 1 : 0;
            }
        });
    for (long long c : shared_rows) shared[i] += c;
    stats.points_shared += shared[i];
  }
  for (int i = 0; i < n; ++i)
    if (shared[i] == 0) stats.isolated_scans.push_back(i);
  return stats;
}

}  // namespace aoscan
