/// @file ssao.cpp
/// @brief Screen-space ambient obscurance estimators (paper, obscurance, Alchemy, horizon) with a
/// parallel fast path and a plain serial reference, and the Eq. 10-11 view weights.
#include "ao/ssao.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Geometry>

#include "ao/ssao_kernels.h"
#include "geometry/normal_smoothing.h"

namespace aoscan {
namespace {

using detail::area_factor;
using detail::FrameSetup;
using detail::kAlchemyEpsilon;
using detail::kBlockOrder;
using detail::kHalfPiF;
using detail::kMaxRadiusPx;
using detail::make_setup;
using detail::pattern_class;
using detail::pixel_weight;
using detail::importance_extra_samples;
using detail::PixelAo;
using detail::smoothstep01;

constexpr double kPi = 3.14159265358979323846;
/// Horizon estimator: steps per slice side.
constexpr int kHorizonSteps = 4;

/// 4x4 Bayer order: rotation rank of each pixel class, and a second permutation for the radial
/// jitter (the transposed tile), so neighbouring pixels differ in both.
constexpr int kBayer[kSsaoPatternClasses] = {0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5};
constexpr int kBayerT[kSsaoPatternClasses] = {0, 12, 3, 15, 8, 4, 11, 7, 2, 14, 1, 13, 10, 6, 9, 5};

/// The base-2 radical inverse (van der Corput) of k: its bits mirrored about the binary point.
double radical_inverse(int k) {
  double inv = 0.0, bit = 0.5;
  for (unsigned u = static_cast<unsigned>(k); u != 0; u >>= 1, bit *= 0.5)
    if (u & 1u) inv += bit;
  return inv;
}

double fract(double v) {
  return v - std::floor(v);
}

/// Nearest pixel of an offset in units of the disk radius, centre + floor(offset * radius_px +
/// 0.5), without a libm call: floor by truncation and a correction, exactly std::floor for the
/// arguments that occur (|offset| <= 1, radius <= kMaxRadiusPx), so it gives the pixel of the
/// formula.
inline int offset_px_fast(int centre, float offset, float radius_px) {
  const float v = offset * radius_px + 0.5f;
  const int t = static_cast<int>(v);
  return centre + t - (v < static_cast<float>(t) ? 1 : 0);
}

// ---------------------------------------------------------------------------------------------
// Fast path: estimator-specialised loops over precomputed per-class offsets.

/// The vector v = q - p from the centre point p to the surface point q under the screen offset
/// `offset` (unit disk, scaled by rx, ry pixels) of pixel (x, y), and d2 = |v|^2; false when the
/// sample falls outside the image, on the pixel itself, on a pixel without a surface or on p.
inline bool sample_vector(const PointMaps& maps, int x, int y, const Eigen::Vector2f& offset,
                          float rx, float ry, const Eigen::Vector3f& p, Eigen::Vector3f& v,
                          float& d2, std::size_t& index) {
  const int w = maps.vertices.width();
  const int h = maps.vertices.height();
  const int sx = offset_px_fast(x, offset.x(), rx);
  const int sy = offset_px_fast(y, offset.y(), ry);
  if (sx < 0 || sy < 0 || sx >= w || sy >= h || (sx == x && sy == y)) return false;
  index = static_cast<std::size_t>(sy) * w + sx;
  const Eigen::Vector3f& q = maps.vertices.data()[index];
  if (!(q.z() > 0.0f) || !q.allFinite()) return false;
  v = q - p;
  d2 = v.squaredNorm();
  return d2 > 0.0f;
}

/// sample_vector() for the slice estimators, which count every usable sample in `counted`.
inline bool slice_sample(const PointMaps& maps, int x, int y, const Eigen::Vector2f& offset,
                         float rx, float ry, const Eigen::Vector3f& p, Eigen::Vector3f& v,
                         float& d2, int& counted) {
  std::size_t index;
  if (!sample_vector(maps, x, y, offset, rx, ry, p, v, d2, index)) return false;
  ++counted;
  return true;
}

/// A GTAO slice: the plane through the view direction and the screen direction `dir`, with the
/// length of the normal projected into it and that projected normal's angle n_ang from the view
/// direction (cos_n = its cosine).
struct Slice {
  float proj_len, cos_n, n_ang;
};

/// Sets up the slice of screen direction `dir`; false when the normal is (nearly) perpendicular
/// to the slice plane.
inline bool make_slice(const Eigen::Vector2f& dir2, const Eigen::Vector3f& view,
                       const Eigen::Vector3f& n, Slice& out) {
  const Eigen::Vector3f dir(dir2.x(), dir2.y(), 0.0f);
  const Eigen::Vector3f ortho = (dir - dir.dot(view) * view).normalized();
  const Eigen::Vector3f axis = ortho.cross(view).normalized();
  const Eigen::Vector3f proj_n = n - axis * n.dot(axis);
  out.proj_len = proj_n.norm();
  if (!(out.proj_len > 1e-6f)) return false;
  out.cos_n = std::min(std::max(proj_n.dot(view) / out.proj_len, 0.0f), 1.0f);
  out.n_ang = (ortho.dot(proj_n) < 0.0f ? -1.0f : 1.0f) * std::acos(out.cos_n);
  return true;
}

template <AoEstimator E>
PixelAo fast_point_ao(const FrameSetup& s, int x, int y, const Eigen::Vector3f& p,
                      const Eigen::Vector3f& n) {
  const PointMaps& maps = *s.maps;
  const int count = s.pattern->samples;
  const Eigen::Vector2f* offs = s.pattern->offsets.data() + pattern_class(x, y) * count;
  const float rx = std::min(s.fx * s.radius_m / p.z(), kMaxRadiusPx);
  const float ry = std::min(s.fy * s.radius_m / p.z(), kMaxRadiusPx);
  const float r2eps = kAlchemyEpsilon * s.radius_m * s.radius_m;
  const float bias_m = E == AoEstimator::kPaper ? 0.0f : s.bias * p.z();
  float sum = 0.0f;
  float distance_sum = 0.0f;  // vardis: sum of min(|v|, r_s) over the counted samples
  int counted = 0;
  const bool area = s.area_min_cos < 1.0f;
  const auto take = [&](int begin, int end) {
    for (int k = begin; k < end; ++k) {
      Eigen::Vector3f v;
      float d2 = 0.0f;
      std::size_t index;
      if (!sample_vector(maps, x, y, offs[k], rx, ry, p, v, d2, index)) continue;
      const float nv = n.dot(v) - bias_m;
      ++counted;
      if (s.vardis) distance_sum += std::min(std::sqrt(d2), s.radius_m);
      if constexpr (E == AoEstimator::kAlchemy) {
        if (!(nv > 0.0f)) continue;  // adds 0, no normal to read
        float term = s.radius_m * nv / (d2 + r2eps);
        if (area)
          term *= area_factor(maps.vertices.data()[index], maps.normals.data()[index],
                              s.area_min_cos);
        sum += term;
      } else {
        const float d = std::sqrt(d2);
        const float rho = smoothstep01(d, s.t_max_m);
        if constexpr (E == AoEstimator::kPaper) {
          sum += rho * (1.0f - std::max(nv / d, 0.0f));
        } else {
          sum += std::max(nv / d, 0.0f) * (1.0f - rho);
        }
      }
    }
  };
  const auto result = [&](int taken) {
    PixelAo r{1.0f, static_cast<float>(counted) / static_cast<float>(taken)};
    if (s.vardis)
      r.distance_weight = 1.0f - (distance_sum + static_cast<float>(taken - counted) * s.radius_m) /
                                     (static_cast<float>(taken) * s.radius_m);
    if (counted == 0) return r;
    const float mean = sum / static_cast<float>(counted);
    r.ao = std::min(std::max(E == AoEstimator::kPaper ? mean : 1.0f - mean, 0.0f), 1.0f);
    return r;
  };
  if (s.importance_samples <= 0) {
    take(0, count);
    return result(count);
  }
  const int first = std::min(s.importance_samples, count);
  take(0, first);
  const PixelAo initial = result(first);
  const int extra =
      importance_extra_samples(count - first, pixel_weight(s, p, n, initial), initial.ao);
  take(first, first + extra);
  return result(first + extra);
}

/// GTAO arc integral of one side with horizon angle `h` about projected-normal angle `n`.
float integrate_arc(float h, float n, float cos_n, float sin_n) {
  return 0.25f * (cos_n + 2.0f * h * sin_n - std::cos(2.0f * h - n));
}

/// The frame the slice estimators (horizon, heightfield) share: the pixel's slice directions and
/// sample offsets, its screen radius for `radius_m`, each slice that make_slice() accepts handed
/// to slice_fn, which returns the slice's {visibility, open} integrals (before the projected
/// normal's length weighs them) and counts the samples it used in `counted`; the pixel's AO is
/// the weighted visibility over the weighted open integral.
template <class SliceFn>
PixelAo slice_ao(const FrameSetup& s, int x, int y, const Eigen::Vector3f& p,
                 const Eigen::Vector3f& n, float radius_m, SliceFn&& slice_fn) {
  const SsaoPattern& pat = *s.pattern;
  const int cls = pattern_class(x, y);
  const Eigen::Vector2f* offs = pat.offsets.data() + cls * pat.samples;
  const Eigen::Vector2f* dirs = pat.slice_dirs.data() + cls * pat.slices;
  const float rx = std::min(s.fx * radius_m / p.z(), kMaxRadiusPx);
  const float ry = std::min(s.fy * radius_m / p.z(), kMaxRadiusPx);
  const Eigen::Vector3f view = -p.normalized();
  float visibility = 0.0f, open = 0.0f;
  int counted = 0;
  for (int sl = 0; sl < pat.slices; ++sl) {
    Slice slice;
    if (!make_slice(dirs[sl], view, n, slice)) continue;
    const std::array<float, 2> vo =
        slice_fn(slice, offs + sl * 2 * pat.steps, rx, ry, view, counted);
    visibility += slice.proj_len * vo[0];
    open += slice.proj_len * vo[1];
  }
  const float coverage = static_cast<float>(counted) / static_cast<float>(pat.samples);
  if (!(open > 0.0f)) return {1.0f, coverage};
  return {std::min(std::max(visibility / open, 0.0f), 1.0f), coverage};
}

PixelAo fast_horizon_ao(const FrameSetup& s, int x, int y, const Eigen::Vector3f& p,
                        const Eigen::Vector3f& n) {
  const PointMaps& maps = *s.maps;
  const int steps = s.pattern->steps;
  return slice_ao(s, x, y, p, n, s.radius_m,
                  [&](const Slice& slice, const Eigen::Vector2f* offs, float rx, float ry,
                      const Eigen::Vector3f& view, int& counted) {
    const float cos_n = slice.cos_n, n_ang = slice.n_ang;
    float horizon_cos[2] = {std::cos(n_ang + kHalfPiF), std::cos(n_ang - kHalfPiF)};
    const float low_cos[2] = {horizon_cos[0], horizon_cos[1]};
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector2f* so = offs + side * steps;
      for (int k = 0; k < steps; ++k) {
        Eigen::Vector3f v;
        float d2 = 0.0f;
        if (!slice_sample(maps, x, y, so[k], rx, ry, p, v, d2, counted)) continue;
        const float d = std::sqrt(d2);
        const float keep = 1.0f - smoothstep01(d, s.t_max_m);
        const float shc = low_cos[side] + (v.dot(view) / d - low_cos[side]) * keep;
        horizon_cos[side] = std::max(horizon_cos[side], shc);
      }
    }
    float h0 = std::acos(std::min(horizon_cos[0], 1.0f));
    float h1 = -std::acos(std::min(horizon_cos[1], 1.0f));
    h0 = n_ang + std::min(h0 - n_ang, kHalfPiF);
    h1 = n_ang + std::max(h1 - n_ang, -kHalfPiF);
    const float sin_n = std::sin(n_ang);
    return std::array<float, 2>{
        integrate_arc(h0, n_ang, cos_n, sin_n) + integrate_arc(h1, n_ang, cos_n, sin_n),
        integrate_arc(n_ang + kHalfPiF, n_ang, cos_n, sin_n) +
            integrate_arc(n_ang - kHalfPiF, n_ang, cos_n, sin_n)};
  });
}

/// Heightfield estimator: per slice side, the samples in order of distance raise the horizon;
/// the directions each sample newly hides (their cosine-weighted arc, GTAO's integral) are
/// blocked at about that sample's distance d and keep rho(d) of their visibility, the directions
/// above the final horizon see nothing (rho = 1). On a heightfield this is Eq. 1 exactly, up to
/// the sample spacing. The bias lowers every sample by bias * depth along the normal.
PixelAo fast_heightfield_ao(const FrameSetup& s, int x, int y, const Eigen::Vector3f& p,
                            const Eigen::Vector3f& n) {
  const PointMaps& maps = *s.maps;
  const int steps = s.pattern->steps;
  const Eigen::Vector3f lowered = n * (s.bias * p.z());
  return slice_ao(s, x, y, p, n, s.t_max_m,
                  [&](const Slice& slice, const Eigen::Vector2f* offs, float rx, float ry,
                      const Eigen::Vector3f& view, int& counted) {
    const float cos_n = slice.cos_n, n_ang = slice.n_ang;
    const float sin_n = std::sin(n_ang);
    float slice_visibility = 0.0f, slice_open = 0.0f;
    for (int side = 0; side < 2; ++side) {
      const float sign = side == 0 ? 1.0f : -1.0f;
      const float tangent = n_ang + sign * kHalfPiF;
      float horizon_cos = std::cos(tangent);
      float arc = integrate_arc(tangent, n_ang, cos_n, sin_n);
      float side_visibility = arc;
      const Eigen::Vector2f* so = offs + side * steps;
      for (int k = 0; k < steps; ++k) {
        Eigen::Vector3f v;
        float d2 = 0.0f;
        if (!slice_sample(maps, x, y, so[k], rx, ry, p, v, d2, counted)) continue;
        const Eigen::Vector3f vb = v - lowered;
        const float vb_len = vb.norm();
        if (!(vb_len > 0.0f)) continue;
        const float c = vb.dot(view) / vb_len;
        if (!(c > horizon_cos)) continue;
        horizon_cos = std::min(c, 1.0f);
        const float new_arc = integrate_arc(sign * std::acos(horizon_cos), n_ang, cos_n, sin_n);
        side_visibility -= (1.0f - smoothstep01(std::sqrt(d2), s.t_max_m)) * (arc - new_arc);
        arc = new_arc;
      }
      slice_visibility += side_visibility;
      slice_open += integrate_arc(tangent, n_ang, cos_n, sin_n);
    }
    return std::array<float, 2>{slice_visibility, slice_open};
  });
}

PixelAo statvo_kernel(const FrameSetup& s, int x, int y, const Eigen::Vector3f& p,
                      const Eigen::Vector3f& n) {
  return statvo_pixel_ao(*s.statvo, s, x, y, p, n);
}

using PixelFn = PixelAo (*)(const FrameSetup&, int, int, const Eigen::Vector3f&,
                            const Eigen::Vector3f&);

PixelFn fast_kernel(AoEstimator e) {
  switch (e) {
    case AoEstimator::kPaper:
      return &fast_point_ao<AoEstimator::kPaper>;
    case AoEstimator::kObscurance:
      return &fast_point_ao<AoEstimator::kObscurance>;
    case AoEstimator::kAlchemy:
      return &fast_point_ao<AoEstimator::kAlchemy>;
    case AoEstimator::kHeightfield:
      return &fast_heightfield_ao;
    case AoEstimator::kStatVo:
      return &statvo_kernel;
    case AoEstimator::kHorizon:
      break;
  }
  return &fast_horizon_ao;
}

}  // namespace

SsaoPattern make_ssao_pattern(const AoConfig& config, std::uint64_t frame_index) {
  SsaoPattern pat;
  pat.estimator = config.estimator;
  // Frame rotation (golden ratio) and radial jitter (plastic number) sequences.
  const double frame_turn = fract(static_cast<double>(frame_index % 1000003) * 0.6180339887498949);
  const double frame_jitter =
      fract(0.5 + static_cast<double>(frame_index % 1000003) * 0.7548776662466927);
  const int n = std::max(config.samples, 1);
  const bool sliced =
      config.estimator == AoEstimator::kHorizon || config.estimator == AoEstimator::kHeightfield;
  if (config.estimator == AoEstimator::kHorizon) {
    pat.steps = kHorizonSteps;
    pat.slices = std::max(1, n / (2 * kHorizonSteps));
    pat.samples = pat.slices * 2 * pat.steps;
  } else if (config.estimator == AoEstimator::kHeightfield) {
    // Two perpendicular slices of N / 4 steps per side (fewer, longer slices measured worse on the
    // exact corner).
    pat.slices = 2;
    pat.steps = std::max(1, n / 4);
    pat.samples = 4 * pat.steps;
  } else {
    pat.samples = n;
  }
  pat.offsets.resize(static_cast<std::size_t>(kSsaoPatternClasses) * pat.samples);
  pat.slice_dirs.resize(static_cast<std::size_t>(kSsaoPatternClasses) * pat.slices);
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));
  // The k-th point sample's ring: k (the Vogel spiral), or with importance sampling the rank of
  // k's base-2 radical inverse, so that the first samples of a pixel already span the disk.
  std::vector<int> radial(static_cast<std::size_t>(pat.samples));
  for (int k = 0; k < pat.samples; ++k) radial[k] = k;
  if (config.importance_samples > 0) {
    std::vector<int> order(radial);
    std::sort(order.begin(), order.end(),
              [](int a, int b) { return radical_inverse(a) < radical_inverse(b); });
    for (int rank = 0; rank < pat.samples; ++rank) radial[order[rank]] = rank;
  }
  for (int c = 0; c < kSsaoPatternClasses; ++c) {
    const double turn = kBayer[c] / 16.0 + frame_turn;
    const double jitter = fract(kBayerT[c] / 16.0 + frame_jitter);
    Eigen::Vector2f* offs = pat.offsets.data() + c * pat.samples;
    if (sliced) {
      for (int sl = 0; sl < pat.slices; ++sl) {
        const double phi = kPi * (sl + fract(turn)) / pat.slices;
        const Eigen::Vector2d dir(std::cos(phi), std::sin(phi));
        pat.slice_dirs[c * pat.slices + sl] = dir.cast<float>();
        for (int side = 0; side < 2; ++side)
          for (int k = 0; k < pat.steps; ++k) {
            const double t = (k + jitter) / pat.steps;
            const double r = std::max(t * t, 1e-3);
            offs[(sl * 2 + side) * pat.steps + k] = (dir * (side == 0 ? r : -r)).cast<float>();
          }
      }
    } else {
      for (int k = 0; k < pat.samples; ++k) {
        const double r = std::sqrt((radial[k] + jitter) / pat.samples);
        const double phi = k * golden_angle + 2.0 * kPi * turn;
        offs[k] = Eigen::Vector2d(r * std::cos(phi), r * std::sin(phi)).cast<float>();
      }
    }
  }
  return pat;
}

bool ssao_pixel_valid(const Eigen::Vector3f& vertex, const Eigen::Vector3f& normal) {
  return vertex.z() > 0.0f && vertex.allFinite() && normal.allFinite() &&
         normal.squaredNorm() > 0.0f;
}

void compute_ssao(const PointMaps& maps, const AoConfig& config, std::uint64_t frame_index,
                  Image<float>& ao, Image<float>& weight) {
  SsaoWorkspace workspace;
  compute_ssao(maps, config, frame_index, ao, weight, workspace);
}

void compute_ssao(const PointMaps& maps, const AoConfig& config, std::uint64_t frame_index,
                  Image<float>& ao, Image<float>& weight, SsaoWorkspace& workspace) {
  const int w = maps.vertices.width();
  const int h = maps.vertices.height();
  ao.resize(w, h, 0.0f);
  weight.resize(w, h, 0.0f);
  if (w == 0 || h == 0 || maps.normals.width() != w || maps.normals.height() != h) return;
  const SsaoPattern pattern = make_ssao_pattern(config, frame_index);
  // The SSAO normals of the whole image at once (the samples' area factor reads them too).
  const PointMaps* in = &maps;
  if (config.normal_radius_px > 0) {
    smooth_model_normals(maps, config.normal_radius_px,
                         static_cast<float>(config.normal_max_distance_m), workspace.smoothed,
                         workspace.smoothing_planes);
    in = &workspace.smoothed;
  }
  FrameSetup setup = make_setup(*in, pattern, config);
  if (config.estimator == AoEstimator::kStatVo) {
    build_statvo_tables(*in, config, workspace.statvo);
    setup.statvo = &workspace.statvo;
  }
  const PixelFn kernel = fast_kernel(config.estimator);
  const Eigen::Vector3f* verts = in->vertices.data();
  const Eigen::Vector3f* norms = in->normals.data();

  if (config.ssao_stride_px <= 1) {
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
      for (int y = rows.begin(); y != rows.end(); ++y) {
        float* ao_row = ao.row(y);
        float* w_row = weight.row(y);
        const std::size_t base = static_cast<std::size_t>(y) * w;
        for (int x = 0; x < w; ++x) {
          const Eigen::Vector3f& p = verts[base + x];
          const Eigen::Vector3f& n = norms[base + x];
          if (!ssao_pixel_valid(p, n)) continue;
          const PixelAo r = kernel(setup, x, y, p, n);
          ao_row[x] = r.ao;
          w_row[x] = pixel_weight(setup, p, n, r);
        }
      }
    });
    return;
  }

  const int first = static_cast<int>(frame_index % 4);
  const int block_rows = (h + 1) / 2;
  tbb::parallel_for(tbb::blocked_range<int>(0, block_rows), [&](const tbb::blocked_range<int>& br) {
    for (int by = br.begin(); by != br.end(); ++by) {
      for (int bx = 0; bx < (w + 1) / 2; ++bx) {
        int ex = -1, ey = -1;
        for (int i = 0; i < 4 && ex < 0; ++i) {
          const int x = 2 * bx + kBlockOrder[(first + i) & 3][0];
          const int y = 2 * by + kBlockOrder[(first + i) & 3][1];
          if (x >= w || y >= h) continue;
          const std::size_t idx = static_cast<std::size_t>(y) * w + x;
          if (ssao_pixel_valid(verts[idx], norms[idx])) ex = x, ey = y;
        }
        if (ex < 0) continue;
        const std::size_t eidx = static_cast<std::size_t>(ey) * w + ex;
        const Eigen::Vector3f& ns = norms[eidx];
        const PixelAo r = kernel(setup, ex, ey, verts[eidx], ns);
        const float value = r.ao;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const int x = 2 * bx + dx, y = 2 * by + dy;
            if (x >= w || y >= h) continue;
            const std::size_t idx = static_cast<std::size_t>(y) * w + x;
            if (ssao_pixel_valid(verts[idx], norms[idx])) ao.data()[idx] = value;
          }
        weight.data()[eidx] = pixel_weight(setup, verts[eidx], ns, r);
      }
    }
  });
}

}  // namespace aoscan
