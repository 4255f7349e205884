/// @file ao_reference.cpp
/// @brief Plain serial per-pixel SSAO (compute_ssao_reference()), written directly from the
/// formulas of ssao.h: one generic function per estimator family, no precomputed tables.
#include "support/ao_reference.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "ao/ssao.h"
#include "ao/ssao_kernels.h"
#include "support/geometry_reference.h"

namespace aoscan {
namespace {

using detail::area_factor;
using Setup = detail::FrameSetup;
using detail::kAlchemyEpsilon;
using detail::kBlockOrder;
using detail::kHalfPiF;
using detail::kMaxRadiusPx;
using detail::pattern_class;
using detail::PixelAo;
using detail::smoothstep01;


/// Nearest pixel of an offset in units of the disk radius.
int offset_px(int centre, float offset, float radius_px) {
  return centre + static_cast<int>(std::floor(offset * radius_px + 0.5f));
}

/// The samples of pixel (x, y): fetch() gives the vertex under a pattern offset, or false when
/// the sample is not counted (outside the image, on the pixel itself, on a pixel without a
/// surface or on p), and counts the ones it gives.
struct Sampler {
  const PointMaps& maps;
  int x, y;
  Eigen::Vector3f p;
  float radius_x, radius_y;
  int counted = 0;

  bool fetch(const Eigen::Vector2f& o, Eigen::Vector3f& q) {
    const int sx = offset_px(x, o.x(), radius_x);
    const int sy = offset_px(y, o.y(), radius_y);
    if (!maps.vertices.contains(sx, sy) || (sx == x && sy == y)) return false;
    q = maps.vertices(sx, sy);
    if (!(q.z() > 0.0f) || !q.allFinite()) return false;
    if (!((q - p).squaredNorm() > 0.0f)) return false;
    ++counted;
    return true;
  }
};

/// Horizon and heightfield estimators: the GTAO slices of the pixel with SSAO normal n.
float slice_estimators_ao(const Setup& s, Sampler& sampler, const Eigen::Vector3f& n) {
  const SsaoPattern& pat = *s.pattern;
  const Eigen::Vector3f& p = sampler.p;
  const int cls = pattern_class(sampler.x, sampler.y);
  const Eigen::Vector3f view = -p.normalized();
  float visibility = 0.0f, open = 0.0f;
  for (int sl = 0; sl < pat.slices; ++sl) {
    const Eigen::Vector2f d2 = pat.slice_dirs[cls * pat.slices + sl];
    const Eigen::Vector3f dir(d2.x(), d2.y(), 0.0f);
    const Eigen::Vector3f ortho = (dir - dir.dot(view) * view).normalized();
    const Eigen::Vector3f axis = ortho.cross(view).normalized();
    const Eigen::Vector3f proj_n = n - axis * n.dot(axis);
    const float proj_len = proj_n.norm();
    if (!(proj_len > 1e-6f)) continue;
    const float cos_n = std::clamp(proj_n.dot(view) / proj_len, 0.0f, 1.0f);
    const float n_ang = (ortho.dot(proj_n) < 0.0f ? -1.0f : 1.0f) * std::acos(cos_n);
    // Cosine-weighted measure of the slice directions between the view vector and angle a.
    auto arc = [&](float a) {
      return 0.25f * (cos_n + 2.0f * a * std::sin(n_ang) - std::cos(2.0f * a - n_ang));
    };
    // What the slice sees with nothing above the tangent plane: not 1 per slice off the view
    // axis (only the mean over slice directions is), so the AO is the ratio of the two.
    open += proj_len * (arc(n_ang + kHalfPiF) + arc(n_ang - kHalfPiF));
    if (pat.estimator == AoEstimator::kHeightfield) {
      for (int side = 0; side < 2; ++side) {
        const float sign = side == 0 ? 1.0f : -1.0f;
        float horizon = n_ang + sign * kHalfPiF;  // the tangent plane
        float slice_side = arc(horizon);
        for (int k = 0; k < pat.steps; ++k) {
          Eigen::Vector3f q;
          if (!sampler.fetch(pat.offsets[cls * pat.samples + (sl * 2 + side) * pat.steps + k], q))
            continue;
          const Eigen::Vector3f lowered = q - p - n * (s.bias * p.z());
          if (!(lowered.norm() > 0.0f)) continue;
          const float angle =
              sign * std::acos(std::clamp(lowered.dot(view) / lowered.norm(), -1.0f, 1.0f));
          if (!(std::abs(angle) < std::abs(horizon))) continue;
          // Directions between the old and the new horizon hit this sample's surface.
          const float rho = smoothstep01((q - p).norm(), s.t_max_m);
          slice_side -= (1.0f - rho) * (arc(horizon) - arc(angle));
          horizon = angle;
        }
        visibility += proj_len * slice_side;
      }
      continue;
    }
    float h[2];
    for (int side = 0; side < 2; ++side) {
      const float low = std::cos(side == 0 ? n_ang + kHalfPiF : n_ang - kHalfPiF);
      float best = low;
      for (int k = 0; k < pat.steps; ++k) {
        Eigen::Vector3f q;
        if (!sampler.fetch(pat.offsets[cls * pat.samples + (sl * 2 + side) * pat.steps + k], q))
          continue;
        const float dist = (q - p).norm();
        const float rho = smoothstep01(dist, s.t_max_m);
        best = std::max(best, low + ((q - p).dot(view) / dist - low) * (1.0f - rho));
      }
      h[side] = std::acos(std::min(best, 1.0f));
    }
    const float h0 = n_ang + std::min(h[0] - n_ang, kHalfPiF);
    const float h1 = n_ang + std::max(-h[1] - n_ang, -kHalfPiF);
    visibility += proj_len * (arc(h0) + arc(h1));
  }
  if (!(open > 0.0f)) return 1.0f;
  return std::clamp(visibility / open, 0.0f, 1.0f);
}

/// The plain pixel weight: the paper's w_d * w_n or Vardis et al.'s b * w_d + (1 - b) * w_n with
/// the distance weight of `r`, times coverage^power.
float reference_weight(const Setup& s, const Eigen::Vector3f& p, const Eigen::Vector3f& n,
                       const PixelAo& r) {
  float w = view_weight(p, n, s.d_min_m, s.d_max_m);
  if (s.vardis) {
    const float w_n = std::max(-n.dot(p) / p.norm(), 0.0f);
    w = s.vardis_b * r.distance_weight + (1.0f - s.vardis_b) * w_n;
  }
  if (s.coverage_power > 0.0f) w *= std::pow(std::clamp(r.coverage, 0.0f, 1.0f), s.coverage_power);
  return w;
}

/// Paper, obscurance and alchemy estimators: the mean over the counted point samples of the
/// samples taken (all N, or with importance sampling the first n and then as many more as Eq. 6
/// of Vardis et al. gives), with the coverage and the distance weight of the samples taken.
PixelAo point_estimators_ao(const Setup& s, Sampler& sampler, const Eigen::Vector3f& n) {
  const SsaoPattern& pat = *s.pattern;
  const PointMaps& maps = *s.maps;
  const Eigen::Vector3f& p = sampler.p;
  const int cls = pattern_class(sampler.x, sampler.y);
  float sum = 0.0f, distances = 0.0f;
  auto take = [&](int k) {
    Eigen::Vector3f q;
    const Eigen::Vector2f& o = pat.offsets[cls * pat.samples + k];
    if (!sampler.fetch(o, q)) return;
    const Eigen::Vector3f v = q - p;
    const float dist = v.norm();
    distances += std::min(dist, s.radius_m);
    const float rho = smoothstep01(dist, s.t_max_m);
    const float height = n.dot(v) - s.bias * p.z();  // above the tangent plane, less the bias
    const float c = height / dist;
    switch (pat.estimator) {
      case AoEstimator::kPaper:  // Eq. 3-5
        sum += rho * (1.0f - std::max(n.dot(v) / dist, 0.0f));
        break;
      case AoEstimator::kObscurance:
        sum += std::max(c, 0.0f) * (1.0f - rho);
        break;
      case AoEstimator::kAlchemy: {
        float term = s.radius_m * std::max(height, 0.0f) /
                     (v.squaredNorm() + kAlchemyEpsilon * s.radius_m * s.radius_m);
        // The sample's pixel covers surface area in proportion to 1 / cos theta_q.
        if (s.area_min_cos < 1.0f && height > 0.0f)
          term *= area_factor(q,
                              maps.normals(offset_px(sampler.x, o.x(), sampler.radius_x),
                                           offset_px(sampler.y, o.y(), sampler.radius_y)),
                              s.area_min_cos);
        sum += term;
        break;
      }
      case AoEstimator::kHorizon:
      case AoEstimator::kHeightfield:
      case AoEstimator::kStatVo:
        break;
    }
  };
  auto result = [&](int taken) {
    PixelAo r{1.0f, static_cast<float>(sampler.counted) / static_cast<float>(taken)};
    if (s.vardis)
      r.distance_weight =
          1.0f - (distances + static_cast<float>(taken - sampler.counted) * s.radius_m) /
                     (static_cast<float>(taken) * s.radius_m);
    if (sampler.counted > 0) {
      const float mean = sum / static_cast<float>(sampler.counted);
      r.ao = std::clamp(pat.estimator == AoEstimator::kPaper ? mean : 1.0f - mean, 0.0f, 1.0f);
    }
    return r;
  };
  int taken = s.importance_samples > 0 ? std::min(s.importance_samples, pat.samples) : pat.samples;
  for (int k = 0; k < taken; ++k) take(k);
  if (taken < pat.samples) {
    const PixelAo initial = result(taken);
    const int remaining = pat.samples - taken;
    const float share = std::clamp(reference_weight(s, p, n, initial), 0.0f, 1.0f) *
                        (1.0f + (1.0f - initial.ao)) * 0.5f;
    const int extra =
        std::min(remaining, static_cast<int>(std::floor(remaining * share + 0.5f)));
    for (int k = taken; k < taken + extra; ++k) take(k);
    taken += extra;
  }
  return result(taken);
}

/// statvo (ao/statvo.h) from its definition, by direct sums over each pixel's box: the pixels'
/// layers (bit 1: the far half of all valid pixels, bit 0: the far half of the pixel's first
/// half; -1: invalid), then the pixel's AO and coverage from the four layers' counts and mean
/// positions in its box.
class StatVoReference {
 public:
  StatVoReference(const Setup& s, const std::function<bool(int, int)>& valid)
      : s_(s), maps_(*s.maps), w_(maps_.vertices.width()), h_(maps_.vertices.height()) {
    std::vector<int> first(static_cast<std::size_t>(w_) * h_, -1);
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x)
        if (valid(x, y)) first[index(x, y)] = 0;
    code_ = first;
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x)
        if (first[index(x, y)] >= 0 && far(first, x, y, [](int) { return true; }))
          code_[index(x, y)] = 2;
    const std::vector<int> halves = code_;
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) {
        const int half = halves[index(x, y)];
        if (half >= 0 && far(halves, x, y, [half](int c) { return c == half; }))
          ++code_[index(x, y)];
      }
  }

  PixelAo pixel(int x, int y) const {
    const Eigen::Vector3f p = maps_.vertices(x, y);
    const Eigen::Vector3f n = maps_.normals(x, y);
    const int hx = detail::statvo_half_px(s_.fx, s_.radius_m, p.z());
    const int hy = detail::statvo_half_px(s_.fy, s_.radius_m, p.z());
    Eigen::Vector3d sum[4] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    double count[4] = {0, 0, 0, 0};
    for (int v = y - hy; v <= y + hy; ++v)
      for (int u = x - hx; u <= x + hx; ++u) {
        if (!maps_.vertices.contains(u, v) || code_[index(u, v)] < 0) continue;
        sum[code_[index(u, v)]] += maps_.vertices(u, v).cast<double>();
        count[code_[index(u, v)]] += 1.0;
      }
    double occluded = 0.0, counted = 0.0;
    for (int i = 0; i < 4; ++i) {
      if (count[i] == 0.0) continue;
      const double height = (sum[i] / count[i] - p.cast<double>()).dot(n.cast<double>()) -
                            static_cast<double>(s_.bias) * p.z();
      occluded += detail::statvo_psi(static_cast<float>(height / s_.radius_m),
                                     1.0f + s_.t_max_m / s_.radius_m) *
                  count[i];
      counted += count[i];
    }
    const double area = static_cast<double>(2 * hx + 1) * (2 * hy + 1);
    return {static_cast<float>(1.0 - occluded / counted), static_cast<float>(counted / area)};
  }

 private:
  std::size_t index(int x, int y) const { return static_cast<std::size_t>(y) * w_ + x; }

  /// Whether pixel (x, y) lies kStatVoTieM or more behind the mean depth of the pixels of its box
  /// whose code passes `member`.
  template <class Member>
  bool far(const std::vector<int>& codes, int x, int y, Member member) const {
    const float z = maps_.vertices(x, y).z();
    const int hx = detail::statvo_half_px(s_.fx, s_.radius_m, z);
    const int hy = detail::statvo_half_px(s_.fy, s_.radius_m, z);
    double sum_z = 0.0, count = 0.0;
    for (int v = y - hy; v <= y + hy; ++v)
      for (int u = x - hx; u <= x + hx; ++u) {
        if (!maps_.vertices.contains(u, v)) continue;
        const int c = codes[index(u, v)];
        if (c < 0 || !member(c)) continue;
        sum_z += maps_.vertices(u, v).z();
        count += 1.0;
      }
    return static_cast<double>(z) - sum_z / count >= detail::kStatVoTieM;
  }

  const Setup& s_;
  const PointMaps& maps_;
  int w_, h_;
  std::vector<int> code_;
};

/// The SSAO of pixel (x, y) and its coverage.
PixelAo reference_pixel_ao(const Setup& s, int x, int y) {
  const PointMaps& maps = *s.maps;
  const SsaoPattern& pat = *s.pattern;
  const Eigen::Vector3f p = maps.vertices(x, y);
  const Eigen::Vector3f n = maps.normals(x, y);  // the SSAO normal (smoothed map)
  // The disk's radius: r_s, or t_max for the heightfield estimator, which marches out to where
  // rho reaches 1.
  const float disk_m = pat.estimator == AoEstimator::kHeightfield ? s.t_max_m : s.radius_m;
  Sampler sampler{maps, x, y, p, std::min(s.fx * disk_m / p.z(), kMaxRadiusPx),
                  std::min(s.fy * disk_m / p.z(), kMaxRadiusPx)};
  const bool slices =
      pat.estimator == AoEstimator::kHorizon || pat.estimator == AoEstimator::kHeightfield;
  if (!slices) return point_estimators_ao(s, sampler, n);
  const float ao = slice_estimators_ao(s, sampler, n);
  return {ao, static_cast<float>(sampler.counted) / static_cast<float>(pat.samples)};
}

}  // namespace

void compute_ssao_reference(const PointMaps& maps, const AoConfig& config,
                            std::uint64_t frame_index, Image<float>& ao, Image<float>& weight) {
  const int w = maps.vertices.width();
  const int h = maps.vertices.height();
  ao.resize(w, h, 0.0f);
  weight.resize(w, h, 0.0f);
  if (w == 0 || h == 0 || maps.normals.width() != w || maps.normals.height() != h) return;
  const SsaoPattern pattern = make_ssao_pattern(config, frame_index);
  PointMaps smoothed_maps;
  if (config.normal_radius_px > 0)
    smooth_model_normals_reference(maps, config.normal_radius_px,
                                   static_cast<float>(config.normal_max_distance_m),
                                   smoothed_maps);
  const PointMaps& maps_in = config.normal_radius_px > 0 ? smoothed_maps : maps;
  const Setup setup = detail::make_setup(maps_in, pattern, config);
  auto valid = [&](int x, int y) {
    return maps_in.vertices.contains(x, y) &&
           ssao_pixel_valid(maps_in.vertices(x, y), maps_in.normals(x, y));
  };
  std::optional<StatVoReference> statvo;
  if (config.estimator == AoEstimator::kStatVo) statvo.emplace(setup, valid);
  const int stride = config.ssao_stride_px <= 1 ? 1 : 2;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (!valid(x, y)) continue;
      // The pixel of this pixel's block that is evaluated this frame.
      int ex = x, ey = y;
      if (stride == 2) {
        for (int i = 3; i >= 0; --i) {
          const int* o = kBlockOrder[(frame_index % 4 + i) & 3];
          if (valid(x - x % 2 + o[0], y - y % 2 + o[1]))
            ex = x - x % 2 + o[0], ey = y - y % 2 + o[1];
        }
      }
      const PixelAo r = statvo ? statvo->pixel(ex, ey) : reference_pixel_ao(setup, ex, ey);
      ao(x, y) = r.ao;
      if (ex == x && ey == y)
        weight(x, y) = reference_weight(setup, maps_in.vertices(x, y), maps_in.normals(x, y), r);
    }
  }
}

}  // namespace aoscan
