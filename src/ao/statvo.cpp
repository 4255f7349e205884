/// @file statvo.cpp
/// @brief The `statvo` estimator of statvo.h: layered summed-area tables and their per-pixel
/// evaluation.
#include "ao/statvo.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "ao/ssao_kernels.h"

namespace aoscan {
namespace {

constexpr std::uint8_t kInvalid = 255;

/// Layer codes: bit 1 = the far half of the first partition, bit 0 = the far half of the second.
constexpr std::uint8_t kFarHalf = 2;

/// The sum of table `s` (row length w1 = width + 1) over the pixels [x0, x1] x [y0, y1].
inline Eigen::Vector4d box_sum(const std::vector<Eigen::Vector4d>& s, int w1, int x0, int y0,
                               int x1, int y1) {
  const std::size_t top = static_cast<std::size_t>(y0) * w1;
  const std::size_t bottom = static_cast<std::size_t>(y1 + 1) * w1;
  return s[bottom + x1 + 1] - s[top + x1 + 1] - s[bottom + x0] + s[top + x0];
}

/// The box of a pixel at (x, y) with depth z, clipped to the image.
struct Box {
  int x0, y0, x1, y1, hx, hy;
};
inline Box pixel_box(const detail::FrameSetup& s, int w, int h, int x, int y, float z) {
  Box b;
  b.hx = detail::statvo_half_px(s.fx, s.radius_m, z);
  b.hy = detail::statvo_half_px(s.fy, s.radius_m, z);
  b.x0 = std::max(x - b.hx, 0);
  b.y0 = std::max(y - b.hy, 0);
  b.x1 = std::min(x + b.hx, w - 1);
  b.y1 = std::min(y + b.hy, h - 1);
  return b;
}

/// Table `s` of the valid pixels whose layer code satisfies `member`.
template <class Member>
void build_table(const PointMaps& maps, const std::vector<std::uint8_t>& layer, Member member,
                 std::vector<Eigen::Vector4d>& s) {
  const int w = maps.vertices.width();
  const int h = maps.vertices.height();
  const int w1 = w + 1;
  // Every entry is written below but the first row and column, which stay zero: no clearing of
  // the whole table each frame.
  s.resize(static_cast<std::size_t>(w1) * (h + 1));
  std::fill(s.begin(), s.begin() + w1, Eigen::Vector4d::Zero());
  const Eigen::Vector3f* verts = maps.vertices.data();
  for (int y = 0; y < h; ++y) {
    Eigen::Vector4d running = Eigen::Vector4d::Zero();
    const std::size_t in = static_cast<std::size_t>(y) * w;
    const Eigen::Vector4d* above = s.data() + static_cast<std::size_t>(y) * w1;
    Eigen::Vector4d* out = s.data() + static_cast<std::size_t>(y + 1) * w1;
    out[0] = Eigen::Vector4d::Zero();
    for (int x = 0; x < w; ++x) {
      const std::uint8_t code = layer[in + x];
      if (code != kInvalid && member(code)) {
        const Eigen::Vector3f& v = verts[in + x];
        running += Eigen::Vector4d(v.x(), v.y(), v.z(), 1.0);
      }
      out[x + 1] = above[x + 1] + running;
    }
  }
}

/// Splits every valid pixel whose code has `mask` bits equal to `value` by its depth against the
/// mean depth of those pixels in its box, `sums(box)` giving their (x, y, z, count); the far ones
/// get `far_bit`.
template <class Sums>
void partition(const PointMaps& maps, const detail::FrameSetup& s, std::uint8_t mask,
               std::uint8_t value, std::uint8_t far_bit, Sums sums,
               std::vector<std::uint8_t>& layer) {
  const int w = maps.vertices.width();
  const int h = maps.vertices.height();
  const Eigen::Vector3f* verts = maps.vertices.data();
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        if (layer[i] == kInvalid || (layer[i] & mask) != value) continue;
        const float z = verts[i].z();
        const Box b = pixel_box(s, w, h, x, y, z);
        const Eigen::Vector4d a = sums(b);
        // The pixel itself is one of the counted, so the count is at least 1. Farther than the
        // mean by kStatVoTieM or more: ties (a symmetric scene) split the same way whatever the
        // order of the sums.
        if (static_cast<double>(z) * a.w() - a.z() >= detail::kStatVoTieM * a.w())
          layer[i] |= far_bit;
      }
  });
}

}  // namespace

void build_statvo_tables(const PointMaps& maps, const AoConfig& config, StatVoTables& t) {
  const int w = maps.vertices.width();
  const int h = maps.vertices.height();
  t.width = w;
  t.height = h;
  const int w1 = w + 1;
  const SsaoPattern no_pattern;
  const detail::FrameSetup s = detail::make_setup(maps, no_pattern, config);
  t.layer.resize(static_cast<std::size_t>(w) * h);
  const Eigen::Vector3f* verts = maps.vertices.data();
  const Eigen::Vector3f* norms = maps.normals.data();
  for (std::size_t i = 0; i < t.layer.size(); ++i)
    t.layer[i] = ssao_pixel_valid(verts[i], norms[i]) ? 0 : kInvalid;

  build_table(
      maps, t.layer, [](std::uint8_t) { return true; }, t.s0);
  partition(
      maps, s, 0, 0, kFarHalf,
      [&](const Box& b) -> Eigen::Vector4d { return box_sum(t.s0, w1, b.x0, b.y0, b.x1, b.y1); },
      t.layer);
  build_table(
      maps, t.layer, [](std::uint8_t c) { return (c & kFarHalf) == 0; }, t.s10);
  partition(
      maps, s, kFarHalf, 0, 1,
      [&](const Box& b) -> Eigen::Vector4d { return box_sum(t.s10, w1, b.x0, b.y0, b.x1, b.y1); },
      t.layer);
  partition(
      maps, s, kFarHalf, kFarHalf, 1,
      [&](const Box& b) -> Eigen::Vector4d {  // not an expression of temporaries
        return box_sum(t.s0, w1, b.x0, b.y0, b.x1, b.y1) -
               box_sum(t.s10, w1, b.x0, b.y0, b.x1, b.y1);
      },
      t.layer);
  build_table(
      maps, t.layer, [](std::uint8_t c) { return c == 0; }, t.s20);
  build_table(
      maps, t.layer, [](std::uint8_t c) { return c == kFarHalf; }, t.s22);
}

detail::PixelAo statvo_pixel_ao(const StatVoTables& t, const detail::FrameSetup& s, int x, int y,
                                const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
  const int w1 = t.width + 1;
  const Box b = pixel_box(s, t.width, t.height, x, y, p.z());
  const Eigen::Vector4d a0 = box_sum(t.s0, w1, b.x0, b.y0, b.x1, b.y1);
  const Eigen::Vector4d a10 = box_sum(t.s10, w1, b.x0, b.y0, b.x1, b.y1);
  const Eigen::Vector4d a20 = box_sum(t.s20, w1, b.x0, b.y0, b.x1, b.y1);
  const Eigen::Vector4d a22 = box_sum(t.s22, w1, b.x0, b.y0, b.x1, b.y1);
  const Eigen::Vector4d leaves[4] = {a20, a10 - a20, a22, a0 - a10 - a22};
  const Eigen::Vector3d pd = p.cast<double>();
  const Eigen::Vector3d nd = n.cast<double>();
  const double lift = static_cast<double>(s.bias) * p.z();
  const float falloff_end = 1.0f + s.t_max_m / s.radius_m;
  double occluded = 0.0, counted = 0.0;
  for (const Eigen::Vector4d& a : leaves) {
    if (!(a.w() > 0.5)) continue;
    const double height = (a.head<3>() / a.w() - pd).dot(nd) - lift;
    occluded += detail::statvo_psi(static_cast<float>(height / s.radius_m), falloff_end) * a.w();
    counted += a.w();
  }
  const double area = static_cast<double>(2 * b.hx + 1) * (2 * b.hy + 1);
  if (!(counted > 0.0)) return {1.0f, 0.0f};
  return {static_cast<float>(1.0 - occluded / counted), static_cast<float>(counted / area)};
}

}  // namespace aoscan
