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
#include "core/status.h"

namespace aoscan {
namespace {

using detail::area_factor;
using detail::kAlchemyEpsilon;
using detail::kMaxRadiusPx;
using detail::pattern_class;
using detail::round_half_away;
using detail::smoothstep01;

/// Bits of a pixel's kind: it has a point; it has a point and a normal (it gets an SSAO).
constexpr std::uint8_t kPoint = 1;
constexpr std::uint8_t kNormal = 2;

/// The pixel with a point that a sample at offset (du, dv) pixels from pixel (x, y) reads: the
/// pixel nearest to it or, when that is a hole, the neighbour on the side the offset leans to,
/// along the axis it leans to more, then the other axis, then the diagonal. A map rebuilt from
/// a cloud (Sec. 7) holds a point in about half of its pixels; without this a sample falling
/// between two points would be lost and the pixel's AO rest on half of its samples. False when
/// the sample leaves a pinhole map (an equirectangular one has no edge: onto_map()) or none of
/// those pixels has a point.
bool sample_pixel(const Image<std::uint8_t>& kind, int x, int y, float du, float dv, bool wrap,
                  int& sx, int& sy) {
  const int w = kind.width(), h = kind.height();
  const long iu = round_half_away(du), iv = round_half_away(dv);
  int x0 = x + static_cast<int>(iu);
  int y0 = y + static_cast<int>(iv);
  if (!onto_map(x0, y0, w, h, wrap)) return false;
  auto take = [&](int cx, int cy) {
    if (!onto_map(cx, cy, w, h, wrap) || (kind(cx, cy) & kPoint) == 0) return false;
    sx = cx;
    sy = cy;
    return true;
  };
  if (take(x0, y0)) return true;
  const float lean_u = du - static_cast<float>(iu), lean_v = dv - static_cast<float>(iv);
  const int ex = lean_u >= 0.0f ? 1 : -1, ey = lean_v >= 0.0f ? 1 : -1;
  if (std::abs(lean_u) >= std::abs(lean_v)) {
    if (take(x0 + ex, y0) || take(x0, y0 + ey)) return true;
  } else if (take(x0, y0 + ey) || take(x0 + ex, y0)) {
    return true;
  }
  return take(x0 + ex, y0 + ey);
}

/// The position SSAO reads at pixel (x, y): the point, moved along its normal by `offset_m`
/// when there is one (compute_scan_normals()'s plane offsets).
Eigen::Vector3f ssao_point(const RangeMap& map, const Image<float>* offset_m, int x, int y) {
  const Eigen::Vector3f& p = map.points(x, y);
  if (offset_m == nullptr) return p;
  return p + (*offset_m)(x, y) * map.normals(x, y);
}

/// The unsmoothed SSAO of pixel (x, y). On an equirectangular map (`sphere`, its row y) the sample
/// disk is laid across the view ray and projected into the map (ScanCamera::SphereRow::offsets()),
/// so that it spans as many metres along the row as along the column at any latitude and reaches
/// across a pole; on a pinhole map (`sphere` null) it is the image plane's disk of radius_px.
float pixel_ao(const RangeMap& map, const Image<float>* offset_m, const Image<std::uint8_t>& kind,
               const Image<float>* area, const AoConfig& config, const SsaoPattern& pattern, int x,
               int y, const ScanCamera::SphereRow* sphere) {
  const Eigen::Vector3f p = ssao_point(map, offset_m, x, y);
  const Eigen::Vector3f& n = map.normals(x, y);
  const ScanCamera& camera = map.camera;
  const float depth = camera.depth(p);
  const float radius_m = static_cast<float>(config.radius_m);
  const float t_max = static_cast<float>(config.t_max_m);
  const float radius_px =
      std::min(radius_m * camera.pixels_per_metre_at_1m() / depth, kMaxRadiusPx);
  // The disk's radius on the plane across the ray at distance 1: r_s / depth, less where
  // radius_px is capped.
  const float tangent = radius_px / camera.pixels_per_metre_at_1m();
  const AoEstimator estimator =
      pattern.estimator == AoEstimator::kPaper || pattern.estimator == AoEstimator::kAlchemy
          ? pattern.estimator
          : AoEstimator::kObscurance;
  const float bias_m =
      estimator == AoEstimator::kPaper ? 0.0f : static_cast<float>(config.bias) * depth;
  const float r2eps = kAlchemyEpsilon * radius_m * radius_m;
  const int cls = pattern_class(x, y);
  const bool wrap = camera.wraps();
  float sum = 0.0f;
  int counted = 0;
  // The samples' offsets (pixels), a batch at a time.
  constexpr int kBatch = 16;
  std::array<float, kBatch> du, dv;
  const Eigen::Vector2f* offsets =
      &pattern.offsets[static_cast<std::size_t>(cls * pattern.samples)];
  for (int k = 0; k < pattern.samples; ++k) {
    const int j = k % kBatch;
    if (j == 0) {
      const int n = std::min(kBatch, pattern.samples - k);
      if (sphere != nullptr) {
        sphere->offsets(tangent, offsets + k, n, du.data(), dv.data());
      } else {
        for (int b = 0; b < n; ++b) {
          du[b] = offsets[k + b].x() * radius_px;
          dv[b] = offsets[k + b].y() * radius_px;
        }
      }
    }
    int sx = 0, sy = 0;
    if (!sample_pixel(kind, x, y, du[j], dv[j], wrap, sx, sy)) continue;
    if (sx == x && sy == y) continue;
    const Eigen::Vector3f v = ssao_point(map, offset_m, sx, sy) - p;
    const float d2 = v.squaredNorm();
    if (!(d2 > 0.0f)) continue;
    ++counted;
    const float nv = n.dot(v) - bias_m;
    if (estimator == AoEstimator::kAlchemy) {
      if (!(nv > 0.0f)) continue;
      const float term = radius_m * nv / (d2 + r2eps);
      sum += area != nullptr ? term * (*area)(sx, sy) : term;
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

/// Which pixels of `map` have a point, and which also a normal.
Image<std::uint8_t> pixel_kinds(const RangeMap& map) {
  const int w = map.camera.width, h = map.camera.height;
  Image<std::uint8_t> kind(w, h, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x)
        kind(x, y) = static_cast<std::uint8_t>((map.has_point(x, y) ? kPoint : 0) |
                                               (has_normal(map, x, y) ? kNormal : 0));
  });
  return kind;
}

/// smooth_scan_ssao() with the pixels' kinds given.
void smooth(const RangeMap& map, const Image<std::uint8_t>& kind, const Image<float>& raw,
            float sigma_m, Image<float>& ao) {
  const int w = map.camera.width, h = map.camera.height;
  const bool wrap = map.camera.wraps();
  // The paper's taps (sigma 1 px), kept to the bit where a pixel spans sigma_m or less.
  static const std::array<float, 5> kTaps = {0.135335f, 0.606531f, 1.0f, 0.606531f, 0.135335f};
  ao.resize(w, h, 1.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        if ((kind(x, y) & kNormal) == 0) {
          ao(x, y) = 1.0f;
          continue;
        }
        std::array<float, 5> taps = kTaps;
        const float sigma_px =
            sigma_m / point_radius(map.camera, map.camera.depth(map.points(x, y)));
        if (sigma_px < 1.0f) {  // exp(-d^2 / (2 sigma^2)) at d = 1 and 2
          const float t1 = std::exp(-0.5f / (sigma_px * sigma_px));
          const float t2 = (t1 * t1) * (t1 * t1);
          taps = {t2, t1, 1.0f, t1, t2};
        }
        float sum = 0.0f, weights = 0.0f;
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx) {
            int sx = x + dx;
            int sy = y + dy;
            if (!onto_map(sx, sy, w, h, wrap) || (kind(sx, sy) & kNormal) == 0) continue;
            const float k = taps[dx + 2] * taps[dy + 2];
            sum += k * raw(sx, sy);
            weights += k;
          }
        ao(x, y) = sum / weights;
      }
  });
}

}  // namespace

void smooth_scan_ssao(const RangeMap& map, const Image<float>& raw, float sigma_m,
                      Image<float>& ao) {
  if (raw.width() != map.camera.width || raw.height() != map.camera.height)
    throw usage_error(map.name + ": an SSAO image of another size than the map");
  smooth(map, pixel_kinds(map), raw, sigma_m, ao);
}

void compute_scan_ssao(const RangeMap& map, const AoConfig& config, std::uint64_t pattern_index,
                       Image<float>& ao, const Image<float>& plane_offset_m) {
  const int w = map.camera.width, h = map.camera.height;
  if (!plane_offset_m.empty() && (plane_offset_m.width() != w || plane_offset_m.height() != h))
    throw usage_error(map.name + ": plane offsets of another size than the map");
  const Image<float>* offset_m = plane_offset_m.empty() ? nullptr : &plane_offset_m;
  const SsaoPattern pattern = make_ssao_pattern(config, pattern_index);
  // Which pixels have a point, and which also a normal: read about 26 times a pixel below.
  const Image<std::uint8_t> kind = pixel_kinds(map);
  // Alchemy's area factor of every pixel as a sample (read as often): the surface area its
  // pixel stands for, compute_ssao()'s factor from the pixel's own point (its ray to the
  // scanner) and normal; 1 without a normal.
  Image<float> area;
  const auto area_min_cos = static_cast<float>(config.area_min_cos);
  if (pattern.estimator == AoEstimator::kAlchemy && area_min_cos < 1.0f) {
    area.resize(w, h, 1.0f);
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
      for (int y = rows.begin(); y < rows.end(); ++y)
        for (int x = 0; x < w; ++x)
          if ((kind(x, y) & kNormal) != 0)
            area(x, y) = area_factor(map.points(x, y), map.normals(x, y), area_min_cos);
    });
  }
  const Image<float>* area_or_null = area.empty() ? nullptr : &area;
  Image<float> raw(w, h, 1.0f);
  const bool wrap = map.camera.wraps();
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      const ScanCamera::SphereRow sphere =
          wrap ? map.camera.sphere_row(y) : ScanCamera::SphereRow{};
      const ScanCamera::SphereRow* row = wrap ? &sphere : nullptr;
      for (int x = 0; x < w; ++x)
        raw(x, y) = (kind(x, y) & kNormal) != 0
                        ? pixel_ao(map, offset_m, kind, area_or_null, config, pattern, x, y, row)
                        : 1.0f;
    }
  });
  smooth(map, kind, raw, static_cast<float>(kScanSsaoSmoothingShare * config.radius_m), ao);
}

}  // namespace aoscan
