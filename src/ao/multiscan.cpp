/// @file multiscan.cpp
/// @brief Multi-view AO integration of registered scans (Eq. 6-12).
#include "ao/multiscan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Geometry>

#include "ao/ssao.h"
#include "core/status.h"

namespace aoscan {
namespace {

/// Scan j seen from scan i: the rigid transform of scan i's points into scan j's frame, and
/// scanner i's position there.
struct PairFrame {
  Eigen::Matrix3f R;
  Eigen::Vector3f t;
  Eigen::Vector3f scanner_i;
};

/// The accumulated samples of one point.
struct Sum {
  double ao_w = 0.0;
  double w = 0.0;
};

/// Adds the N x N samples of scan j around pixel (px, py) to `sum`; `inv_rad_i` = 1 / rad(p_i).
void add_samples(const ScanAo& scan_j, const MvaoSamples& samples, const PairFrame& f, int px,
                 int py, float inv_rad_i, const MultiScanParams& params, Sum& sum) {
  const RangeMap& map = scan_j.map;
  const int half = params.neighbourhood / 2;
  const bool wrap = map.camera.wraps();
  for (int dy = -half; dy <= half; ++dy)
    for (int dx = -half; dx <= half; ++dx) {
      int x = px + dx;
      int y = py + dy;
      if (!onto_map(x, y, map.camera.width, map.camera.height, wrap)) continue;
      const MvaoSamples::Sample& s = samples(x, y);
      if (!(s.weight > 0.0f)) continue;  // no point there, or a weight of 0
      if (!((f.scanner_i - map.points(x, y)).dot(map.normals(x, y)) > 0.0f))
        continue;  // not visible from scanner i
      float w = s.weight;
      if (params.border_weight) w *= std::min(s.border * inv_rad_i, 1.0f);
      if (!(w > 0.0f)) continue;
      sum.ao_w += static_cast<double>(w) * s.ssao;
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

void check_neighbourhood(int n) {
  if (n < 1 || n > 9 || n % 2 == 0)
    throw usage_error("multi-scan AO: the neighbourhood must be 1, 3, 5, 7 or 9 (got " +
                      std::to_string(n) + ")");
}

}  // namespace

Eigen::AlignedBox3f scan_world_box(const RangeMap& map) {
  Eigen::AlignedBox3f box;
  const Eigen::Matrix3f R = map.T_world_scanner.rotation().cast<float>();
  const Eigen::Vector3f t = map.T_world_scanner.translation().cast<float>();
  for (int y = 0; y < map.points.height(); ++y)
    for (int x = 0; x < map.points.width(); ++x)
      if (map.has_point(x, y)) box.extend(R * map.points(x, y) + t);
  return box;
}

bool scan_boxes_meet(const Eigen::AlignedBox3f& a, const Eigen::AlignedBox3f& b, float margin_m) {
  if (a.isEmpty() || b.isEmpty()) return false;
  Eigen::AlignedBox3f grown = b;
  grown.min().array() -= margin_m;
  grown.max().array() += margin_m;
  return grown.intersects(a);
}

namespace {

/// How far apart corresponding_pixel()'s noise test lets two points of range noise sigma_a and
/// sigma_b lie.
float noise_reach(float sigma_a, float sigma_b) {
  return 2.0f * (kNoiseMatchFactor * std::sqrt(sigma_a * sigma_a + sigma_b * sigma_b));
}

/// corresponding_pixel() once q's pixel (px, py) is known.
/// `noisy`: noise_i or map_j.noise is known (the noise test is skipped otherwise).
bool corresponding_pixel_at(const RangeMap& map_j, const Eigen::Vector3f& q, float rad_i,
                            const ScanNoise& noise_i, float depth_i, bool noisy,
                            const Eigen::Vector3f& scanner_i, int& px, int& py) {
  if (!map_j.has_point(px, py)) {
    // A hole: the measured neighbour nearest to q stands for the point at q's pixel.
    const int w = map_j.camera.width, h = map_j.camera.height;
    const bool wrap = map_j.camera.wraps();
    float best = std::numeric_limits<float>::infinity();
    int bx = -1, by = -1;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        int x = px + dx;
        int y = py + dy;
        if (!onto_map(x, y, w, h, wrap) || !map_j.has_point(x, y)) continue;
        const float d2 = (map_j.points(x, y) - q).squaredNorm();
        if (d2 < best) {
          best = d2;
          bx = x;
          by = y;
        }
      }
    if (bx < 0) return false;
    px = bx;
    py = by;
  }
  const Eigen::Vector3f& p_ij = map_j.points(px, py);
  const float depth_j = map_j.camera.depth(p_ij);
  const float t = std::max(rad_i, point_radius(map_j.camera, depth_j));
  const float distance = (q - p_ij).norm();
  if (!(distance < 2.0f * t)) {
    // Farther than the pixels' spacing: within the range noise of the two points?
    if (!noisy || !(distance < noise_reach(noise_i.sigma(depth_i), map_j.noise.sigma(depth_j))))
      return false;
  }
  return (scanner_i - p_ij).dot(map_j.normals(px, py)) > 0.0f;
}

}  // namespace

float pair_margin(const MultiScanParams& params, const ScanNoise& a, const ScanNoise& b) {
  return std::max(params.pair_margin_m, noise_reach(a.max_sigma(), b.max_sigma()));
}

bool corresponding_pixel(const RangeMap& map_j, const Eigen::Vector3f& q, float rad_i,
                         const ScanNoise& noise_i, float depth_i, const Eigen::Vector3f& scanner_i,
                         int& px, int& py) {
  return map_j.camera.pixel_of(q, px, py) &&
         corresponding_pixel_at(map_j, q, rad_i, noise_i, depth_i,
                                noise_i.known() || map_j.noise.known(), scanner_i, px, py);
}

MvaoSamples::MvaoSamples(const ScanAo& scan_j, const MultiScanParams& params) {
  make(scan_j, params);
}

void MvaoSamples::make(const ScanAo& scan_j, const MultiScanParams& params) {
  check_scan(scan_j);
  const RangeMap& map = scan_j.map;
  width_ = map.camera.width;
  height_ = map.camera.height;
  samples_.resize(static_cast<std::size_t>(width_) * height_);
  tbb::parallel_for(tbb::blocked_range<int>(0, height_), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < width_; ++x) {
        Sample& s = samples_[static_cast<std::size_t>(y) * width_ + x];
        s = {0.0f, 0.0f, 1.0f};
        if (!map.has_point(x, y)) continue;
        const Eigen::Vector3f& q = map.points(x, y);
        s.weight = view_weight(q, map.normals(x, y), params.d_min_m, params.d_max_m);
        s.border =
            scan_j.border_px(x, y) * point_radius(map.camera, map.camera.depth(q)) / params.t_p_px;
        s.ssao = scan_j.ssao(x, y);
      }
  });
}

MvaoAccumulator::MvaoAccumulator(const ScanAo& scan_i, const MultiScanParams& params)
    : scan_i_(scan_i), params_(params) {
  check_neighbourhood(params.neighbourhood);
  check_scan(scan_i);
  const std::size_t n = scan_i.map.points.size();
  ao_w_.assign(n, 0.0);
  w_.assign(n, 0.0);
  other_scan_.assign(n, 0);
}

void MvaoAccumulator::add(const ScanAo& scan_j, const MvaoSamples& samples_j, bool same_scan) {
  check_scan(scan_j);
  const RangeMap& map_i = scan_i_.map;
  const RangeMap& map_j = scan_j.map;
  if (samples_j.width() != map_j.camera.width || samples_j.height() != map_j.camera.height)
    throw usage_error(map_j.name + ": its samples were made for a map of another size");
  const Pose T_j_i = map_j.T_world_scanner.inverse() * map_i.T_world_scanner;
  PairFrame f;
  f.R = T_j_i.rotation().cast<float>();
  f.t = T_j_i.translation().cast<float>();
  f.scanner_i = f.t;
  const int width = map_i.camera.width;
  const int half = params_.neighbourhood / 2;
  const bool noisy = map_i.noise.known() || map_j.noise.known();
  tbb::parallel_for(tbb::blocked_range<int>(0, map_i.camera.height),
                    [&](const tbb::blocked_range<int>& rows) {
                      // A row goes in runs of points: first the points' pixels in scan j, projected
                      // together (ScanCamera::pixels_of), with the rows of scan j their samples
                      // will read fetched ahead, then the correspondences and samples, so that a
                      // run's random reads into scan j overlap.
                      constexpr int kRun = 32;
                      float qx[kRun], qy[kRun], qz[kRun], rad[kRun], depth[kRun];
                      int xs[kRun], pxs[kRun], pys[kRun];
                      const int reach = std::max(half, 1);  // rows of scan j read around a pixel
                      for (int y = rows.begin(); y < rows.end(); ++y)
                        for (int x0 = 0; x0 < width; x0 += kRun) {
                          int points = 0;
                          for (int x = x0; x < std::min(x0 + kRun, width); ++x) {
                            if (!map_i.has_point(x, y)) continue;
                            const Eigen::Vector3f& p = map_i.points(x, y);
                            const Eigen::Vector3f q = f.R * p + f.t;
                            qx[points] = q.x();
                            qy[points] = q.y();
                            qz[points] = q.z();
                            depth[points] = map_i.camera.depth(p);
                            rad[points] = point_radius(map_i.camera, depth[points]);
                            xs[points++] = x;
                          }
                          map_j.camera.pixels_of(qx, qy, qz, points, pxs, pys);
                          for (int k = 0; k < points; ++k) {
                            if (pxs[k] < 0) continue;
                            for (int sy = std::max(pys[k] - reach, 0);
                                 sy <= std::min(pys[k] + reach, map_j.camera.height - 1); ++sy) {
                              __builtin_prefetch(&map_j.points(pxs[k], sy));
                              __builtin_prefetch(&map_j.normals(pxs[k], sy));
                              __builtin_prefetch(&samples_j(pxs[k], sy));
                            }
                          }
                          for (int k = 0; k < points; ++k) {
                            int px = pxs[k], py = pys[k];
                            if (px < 0) continue;
                            const Eigen::Vector3f q(qx[k], qy[k], qz[k]);
                            if (!corresponding_pixel_at(map_j, q, rad[k], map_i.noise, depth[k],
                                                        noisy, f.scanner_i, px, py))
                              continue;
                            const std::size_t i = static_cast<std::size_t>(y) * width + xs[k];
                            Sum sum{ao_w_[i], w_[i]};
                            add_samples(scan_j, samples_j, f, px, py, 1.0f / rad[k], params_, sum);
                            if (!same_scan && sum.w > w_[i]) other_scan_[i] = 1;
                            ao_w_[i] = sum.ao_w;
                            w_[i] = sum.w;
                          }
                        }
                    });
}

long long MvaoAccumulator::finish(Image<float>& mvao) const {
  const RangeMap& map = scan_i_.map;
  const int width = map.camera.width;
  mvao.resize(width, map.camera.height, 1.0f);
  long long shared = 0;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < width; ++x) {
      if (!map.has_point(x, y)) continue;
      const std::size_t k = static_cast<std::size_t>(y) * width + x;
      mvao(x, y) = w_[k] > 0.0 ? static_cast<float>(ao_w_[k] / w_[k]) : scan_i_.ssao(x, y);
      shared += other_scan_[k];
    }
  return shared;
}

MultiScanStats integrate_scans(const std::vector<ScanAo>& scans, const MultiScanParams& params,
                               std::vector<Image<float>>& mvao) {
  check_neighbourhood(params.neighbourhood);
  for (const ScanAo& s : scans) check_scan(s);
  MultiScanStats stats;
  const int n = static_cast<int>(scans.size());
  std::vector<Eigen::AlignedBox3f> boxes(n);
  for (int i = 0; i < n; ++i) {
    boxes[i] = scan_world_box(scans[i].map);
    stats.points += scans[i].map.count_points();
  }
  mvao.resize(n);
  std::vector<MvaoSamples> samples;
  samples.reserve(n);
  for (const ScanAo& s : scans) samples.emplace_back(s, params);
  for (int i = 0; i < n; ++i) {
    MvaoAccumulator accumulator(scans[i], params);
    for (int j = 0; j < n; ++j) {
      if (j != i && !scan_boxes_meet(boxes[i], boxes[j],
                                     pair_margin(params, scans[i].map.noise, scans[j].map.noise))) {
        ++stats.pairs_skipped;
        continue;
      }
      if (j != i) ++stats.pairs_tested;
      accumulator.add(scans[j], samples[j], j == i);
    }
    const long long shared = accumulator.finish(mvao[i]);
    stats.points_shared += shared;
    if (shared == 0) stats.isolated_scans.push_back(i);
  }
  return stats;
}

}  // namespace aoscan
