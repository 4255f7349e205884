/// @file scan_ssao.cpp
/// @brief Per-scan SSAO on range maps.
#include "ao/scan_ssao.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "ao/ssao.h"
#include "ao/ssao_kernels.h"

namespace aoscan {
namespace {

using detail::kAlchemyEpsilon;
using detail::kMaxRadiusPx;
using detail::pattern_class;
using detail::smoothstep01;


/// Column x of a map that wraps around in x (equirectangular): one addition or subtraction for
/// the columns just off either edge, the usual case.
inline int wrap_column(int x, int width) {
  if (x < 0) x += width;
  if (x >= width) x -= width;
  if (x < 0 || x >= width) x = ((x % width) + width) % width;  // farther than a width off
  return x;
}

/// The unsmoothed SSAO of pixel (x, y).
float pixel_ao(const RangeMap& map, const AoConfig& config, const SsaoPattern& pattern, int x,
               int y) {
  const Eigen::Vector3f& p = map.points(x, y);
  const Eigen::Vector3f& n = map.normals(x, y);
  const ScanCamera& camera = map.camera;
  const float depth = camera.depth(p);
  const float radius_m = static_cast<float>(config.radius_m);
  const float t_max = static_cast<float>(config.t_max_m);
  const float radius_px =
      std::min(radius_m * camera.pixels_per_metre_at_1m() / depth, kMaxRadiusPx);
  const AoEstimator estimator =
      pattern.estimator == AoEstimator::kPaper || pattern.estimator == AoEstimator::kAlchemy
          ? pattern.estimator
          : AoEstimator::kObscurance;
  const float bias_m =
      estimator == AoEstimator::kPaper ? 0.0f : static_cast<float>(config.bias) * depth;
  const float r2eps = kAlchemyEpsilon * radius_m * radius_m;
  const int cls = pattern_class(x, y);
  const bool wrap = camera.projection == ScanProjection::kEquirectangular;
  float sum = 0.0f;
  int counted = 0;
  for (int k = 0; k < pattern.samples; ++k) {
    const Eigen::Vector2f& o = pattern.offsets[cls * pattern.samples + k];
    int sx = x + static_cast<int>(std::lround(o.x() * radius_px));
    const int sy = y + static_cast<int>(std::lround(o.y() * radius_px));
    if (wrap) sx = wrap_column(sx, camera.width);
    if (sx < 0 || sy < 0 || sx >= camera.width || sy >= camera.height) continue;
    if ((sx == x && sy == y) || !map.has_point(sx, sy)) continue;
    const Eigen::Vector3f v = map.points(sx, sy) - p;
    const float d2 = v.squaredNorm();
    if (!(d2 > 0.0f)) continue;
    ++counted;
    const float nv = n.dot(v) - bias_m;
    if (estimator == AoEstimator::kAlchemy) {
      if (nv > 0.0f) sum += radius_m * nv / (d2 + r2eps);
      continue;
    }
    const float d = std::sqrt(d2);
    const float rho = smoothstep01(d, t_max);
    sum += estimator == AoEstimator::kPaper ? rho * (1.0f - std::max(nv / d, 0.0f))
                                            : std::max(nv / d, 0.0f) * (1.0f - rho);
  }
  if (counted == 0) return 1.0f;
  const float mean = sum / static_cast<float>(counted);
  const float ao = estimator == AoEstimator::kPaper ? mean : 1.0f - mean;
  return std::min(std::max(ao, 0.0f), 1.0f);
}

bool has_normal(const RangeMap& map, int x, int y) {
  const Eigen::Vector3f& n = map.normals(x, y);
  return map.has_point(x, y) && n.allFinite() && n.squaredNorm() > 0.0f;
}

}  // namespace

void compute_scan_ssao(const RangeMap& map, const AoConfig& config, std::uint64_t pattern_index,
                       Image<float>& ao) {
  const int w = map.camera.width, h = map.camera.height;
  const SsaoPattern pattern = make_ssao_pattern(config, pattern_index);
  // Which pixels have a point and a normal: read 26 times a pixel below.
  Image<std::uint8_t> valid(w, h, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x) valid(x, y) = has_normal(map, x, y) ? 1 : 0;
  });
  Image<float> raw(w, h, 1.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x)
        raw(x, y) = valid(x, y) ? pixel_ao(map, config, pattern, x, y) : 1.0f;
  });
  // 5 x 5 Gaussian (sigma 1 px) over the pixels with a normal, renormalised at holes and edges.
  static const std::array<float, 5> kTaps = {0.135335f, 0.606531f, 1.0f, 0.606531f, 0.135335f};
  const bool wrap = map.camera.projection == ScanProjection::kEquirectangular;
  ao.resize(w, h, 1.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        if (!valid(x, y)) {
          ao(x, y) = 1.0f;
          continue;
        }
        float sum = 0.0f, weights = 0.0f;
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx) {
            int sx = x + dx;
            const int sy = y + dy;
            if (wrap) sx = wrap_column(sx, w);
            if (sx < 0 || sy < 0 || sx >= w || sy >= h || !valid(sx, sy)) continue;
            const float k = kTaps[dx + 2] * kTaps[dy + 2];
            sum += k * raw(sx, sy);
            weights += k;
          }
        ao(x, y) = sum / weights;
      }
  });
}

}  // namespace aoscan
