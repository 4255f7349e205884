/// @file jump_flood.cpp
/// @brief Jump flooding distance fields and the border distance of range maps.
#include "ao/jump_flood.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "ao/jump_flood_kernels.h"
#include "core/percentile.h"
#include "geometry/simd.h"

namespace aoscan {

namespace detail {

void flood_interior_portable(const FloodRow& row, int x_begin, int x_end, PackedSeed* out) {
  for (int x = x_begin; x < x_end; ++x) {
    std::int32_t best_d = std::numeric_limits<std::int32_t>::max();
    PackedSeed best = -1;
    for (const PackedSeed* r : row.rows) {
      if (r == nullptr) continue;
      for (int c = -1; c <= 1; ++c) {
        const PackedSeed s = r[x + c * row.k];
        if (s < 0) continue;
        std::int32_t dx = std::abs(x - (s & 0xFFFF));
        if (row.wrap_width > 0) dx = std::min(dx, row.wrap_width - dx);
        const std::int32_t dy = row.y - (s >> 16);
        const std::int32_t d = dx * dx + dy * dy;
        if (d < best_d || (d == best_d && s < best)) {
          best = s;
          best_d = d;
        }
      }
    }
    out[x] = best;
  }
}

}  // namespace detail

namespace {

/// A seed packed as (y << kSeedShift) | x, -1 for none: detail::PackedSeed (32 bits) for images
/// of at most detail::kMaxPackedSide pixels a side, 64 bits for larger ones. Either way seeds
/// compare as their (y, x).
template <typename Seed>
constexpr int kSeedShift = static_cast<int>(sizeof(Seed)) * 4;
template <typename Seed>
constexpr Seed kSeedLowMask = (Seed(1) << kSeedShift<Seed>)-1;

template <typename Seed>
Seed make_seed(int x, int y) {
  return (static_cast<Seed>(y) << kSeedShift<Seed>) | static_cast<Seed>(x);
}

/// Squared distance from (x, y) to seed s, the x difference taken around the cylinder when
/// `wrap_width` > 0.
template <typename Seed>
inline std::int64_t distance_sq(int x, int y, Seed s, int wrap_width) {
  std::int64_t dx = std::abs(x - static_cast<std::int64_t>(s & kSeedLowMask<Seed>));
  if (wrap_width > 0) dx = std::min<std::int64_t>(dx, wrap_width - dx);
  const std::int64_t dy = y - static_cast<std::int64_t>(s >> kSeedShift<Seed>);
  return dx * dx + dy * dy;
}

/// One jump flooding pass of step k from `in` to `out`. Each pixel keeps the nearest of the seeds
/// at the nine pixels (x + i k, y + j k), i, j in {-1, 0, 1}, ties to the smaller seed (so the
/// result does not depend on the order they are visited in). The columns of a packed image's
/// pixels whose nine columns all lie in the image go to detail::flood_interior_*(), the AVX2
/// kernel where the CPU has it and `simd` allows; the others, and every pixel of a wide image,
/// are done here.
template <typename Seed>
void flood_pass(const Image<Seed>& in, int k, bool wrap_x, bool simd, Image<Seed>& out) {
  const int w = in.width(), h = in.height();
  const int wrap_width = wrap_x ? w : 0;
  // The columns x - k, x, x + k of every x (around the cylinder, or -1 off the image), worked out
  // once per pass rather than per pixel.
  std::vector<int> columns(static_cast<std::size_t>(w) * 3);
  for (int x = 0; x < w; ++x)
    for (int c = 0; c < 3; ++c) {
      int nx = x + (c - 1) * k;
      if (wrap_x) {
        nx %= w;
        if (nx < 0) nx += w;
      } else if (nx < 0 || nx >= w) {
        nx = -1;
      }
      columns[static_cast<std::size_t>(x) * 3 + c] = nx;
    }
  constexpr bool packed = std::is_same_v<Seed, detail::PackedSeed>;
  // [interior_begin, interior_end): the columns whose three columns need no wrap.
  const int interior_begin = packed ? std::min(k, w) : w;
  const int interior_end = packed ? std::max(interior_begin, w - k) : w;
#if AOSCAN_JUMP_FLOOD_X86
  const bool avx2 = simd && cpu_has_avx2();
#else
  (void)simd;
#endif
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      const Seed* row[3];
      for (int r = 0; r < 3; ++r) {
        const int ny = y + (r - 1) * k;
        row[r] = ny >= 0 && ny < h ? &in(0, ny) : nullptr;
      }
      Seed* row_out = &out(0, y);
      const auto edge_pixel = [&](int x) {
        Seed best = -1;
        std::int64_t best_d = std::numeric_limits<std::int64_t>::max();
        const int* cols = &columns[static_cast<std::size_t>(x) * 3];
        for (int r = 0; r < 3; ++r) {
          if (row[r] == nullptr) continue;
          for (int c = 0; c < 3; ++c) {
            if (cols[c] < 0) continue;
            const Seed s = row[r][cols[c]];
            if (s < 0) continue;
            const std::int64_t d = distance_sq(x, y, s, wrap_width);
            if (d < best_d || (d == best_d && s < best)) {
              best = s;
              best_d = d;
            }
          }
        }
        row_out[x] = best;
      };
      for (int x = 0; x < interior_begin; ++x) edge_pixel(x);
      if constexpr (packed) {
        const detail::FloodRow flood{{row[0], row[1], row[2]}, y, k, wrap_width};
#if AOSCAN_JUMP_FLOOD_X86
        if (avx2)
          detail::flood_interior_avx2(flood, interior_begin, interior_end, row_out);
        else
#endif
          detail::flood_interior_portable(flood, interior_begin, interior_end, row_out);
      }
      for (int x = interior_end; x < w; ++x) edge_pixel(x);
    }
  });
}

template <typename Seed>
void jump_flood(const Image<std::uint8_t>& seeds, bool wrap_x, bool simd,
                Image<float>& distance_px) {
  const int w = seeds.width(), h = seeds.height();
  Image<Seed> a(w, h, Seed(-1)), b(w, h, Seed(-1));
  bool any = false;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (seeds(x, y) != 0) {
        a(x, y) = make_seed<Seed>(x, y);
        any = true;
      }
  distance_px.resize(w, h, 0.0f);
  if (!any) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) distance_px(x, y) = std::numeric_limits<float>::infinity();
    return;
  }
  int step = 1;
  while (step * 2 < std::max(w, h)) step *= 2;
  for (; step >= 1; step /= 2) {
    flood_pass(a, step, wrap_x, simd, b);
    std::swap(a, b);
  }
  flood_pass(a, 1, wrap_x, simd, b);  // JFA+1
  const int wrap_width = wrap_x ? w : 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      distance_px(x, y) = static_cast<float>(
          std::sqrt(static_cast<double>(distance_sq(x, y, b(x, y), wrap_width))));
}

}  // namespace

void jump_flood_distance(const Image<std::uint8_t>& seeds, bool wrap_x, Image<float>& distance_px,
                         bool simd) {
  if (seeds.width() <= detail::kMaxPackedSide && seeds.height() <= detail::kMaxPackedSide)
    jump_flood<detail::PackedSeed>(seeds, wrap_x, simd, distance_px);
  else
    jump_flood<std::int64_t>(seeds, wrap_x, simd, distance_px);
}

BorderStats border_distance(const RangeMap& map, float min_edge_ratio, Image<float>& distance_px) {
  const int w = map.points.width(), h = map.points.height();
  const bool wrap = map.camera.wraps();
  Image<float> depth(w, h, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      depth(x, y) = map.has_point(x, y) ? map.camera.depth(map.points(x, y)) : 0.0f;
  auto at = [&](int x, int y) { return onto_map(x, y, w, h, wrap) ? depth(x, y) : 0.0f; };
  // A pixel of the map without a point that has one within kDropoutRadiusPx on both sides along
  // its row or its column.
  auto dropout = [&](int x, int y) {
    auto side = [&](int dx, int dy) {
      for (int k = 1; k <= kDropoutRadiusPx; ++k)
        if (at(x + k * dx, y + k * dy) > 0.0f) return true;
      return false;
    };
    return onto_map(x, y, w, h, wrap) &&
           ((side(-1, 0) && side(1, 0)) || (side(0, -1) && side(0, 1)) ||
            (at(x - 1, y - 1) > 0.0f && at(x + 1, y + 1) > 0.0f) ||
            (at(x - 1, y + 1) > 0.0f && at(x + 1, y - 1) > 0.0f));
  };
  Image<float> laplacian(w, h, 0.0f);
  std::vector<float> values;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float centre = depth(x, y);
      if (!(centre > 0.0f)) continue;
      // A neighbour that is a dropout reads the pixel's own depth: no edge.
      auto neighbour = [&](int nx, int ny) {
        const float v = at(nx, ny);
        return v > 0.0f || !dropout(nx, ny) ? v : centre;
      };
      const float l = std::abs(4.0f * centre - neighbour(x - 1, y) - neighbour(x + 1, y) -
                               neighbour(x, y - 1) - neighbour(x, y + 1));
      laplacian(x, y) = l;
      values.push_back(l);
    }
  BorderStats stats;
  distance_px.resize(w, h, 0.0f);
  if (values.empty()) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) distance_px(x, y) = 0.0f;
    return stats;
  }
  // The 0.95 percentile by nearest rank: the value with 95 % of the values at or below it.
  const std::size_t rank = nearest_rank_index(values.size(), 0.95);
  std::nth_element(values.begin(), values.begin() + rank, values.end());
  stats.threshold = values[rank];
  const std::size_t middle = nearest_rank_index(values.size(), 0.5);
  std::nth_element(values.begin(), values.begin() + middle, values.end());
  stats.threshold = std::max(stats.threshold, kBorderNoiseMedians * values[middle]);
  Image<std::uint8_t> seeds(w, h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float d = depth(x, y);
      if (d > 0.0f && laplacian(x, y) >= stats.threshold && laplacian(x, y) > min_edge_ratio * d) {
        seeds(x, y) = 1;
        ++stats.edges;
      }
    }
  jump_flood_distance(seeds, wrap, distance_px);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (!(depth(x, y) > 0.0f)) distance_px(x, y) = 0.0f;
  return stats;
}

}  // namespace aoscan
