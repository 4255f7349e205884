/// @file mesh_ao.cpp
/// @brief Per-vertex AO from the MVAO grid: trilinear sampling with an exact nearest-observed-cell
/// fallback through coarse 8x8x8-cell buckets.
#include "ao/mesh_ao.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace aoscan {
namespace {

constexpr int kBucketShift = 3;  // buckets of 8x8x8 cells
constexpr int kBucketCells = 1 << kBucketShift;
constexpr int kMaxBucketShells = 32;  // beyond this the search scans every cell

/// Exact nearest observed cell centre to a point, over a snapshot of the grid's cells.
class NearestCells {
 public:
  explicit NearestCells(const MvaoGrid& grid) : cell_size_m_(grid.cell_size_m()) {
    grid.for_each_cell([&](const CellIndex& c, const MvaoCell& cell) {
      const int id = static_cast<int>(centres_.size());
      centres_.push_back(grid.cell_centre(c));
      values_.push_back(cell.ao());
      buckets_[key(c[0] >> kBucketShift, c[1] >> kBucketShift, c[2] >> kBucketShift)].push_back(id);
    });
  }

  bool empty() const { return centres_.empty(); }

  /// AO of the observed cell nearest to `p` (finite, world metres).
  float nearest(const Eigen::Vector3d& p) const {
    const double bucket_m = cell_size_m_ * kBucketCells;
    const Eigen::Vector3d b = (p / bucket_m).array().floor();
    const double limit = std::ldexp(1.0, 21 - kBucketShift);
    if ((b.array().abs() > limit).any()) return scan_all(p);
    const std::int64_t bx = static_cast<std::int64_t>(b.x()), by = static_cast<std::int64_t>(b.y()),
                       bz = static_cast<std::int64_t>(b.z());
    double best_d2 = std::numeric_limits<double>::infinity();
    int best = -1;
    for (int r = 0; r <= kMaxBucketShells; ++r) {
      const double min_dist = std::max(r - 1, 0) * bucket_m;
      if (best >= 0 && min_dist * min_dist > best_d2) return values_[best];
      for (int dz = -r; dz <= r; ++dz)
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;
            const auto it = buckets_.find(key(bx + dx, by + dy, bz + dz));
            if (it == buckets_.end()) continue;
            for (int id : it->second) consider(p, id, best, best_d2);
          }
    }
    return best >= 0 ? values_[best] : scan_all(p);
  }

 private:
  static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) {
    const auto u = [](std::int64_t v) { return static_cast<std::uint64_t>(v) & 0x1FFFFFu; };
    return u(x) | u(y) << 21 | u(z) << 42;
  }
  /// Equally near cells (common: mesh vertices lie on voxel edges, which are cell faces of the
  /// grid) go to the lexicographically smallest centre, so the result does not depend on the
  /// order in which the grid lists its cells.
  void consider(const Eigen::Vector3d& p, int id, int& best, double& best_d2) const {
    const double d2 = (centres_[id] - p).squaredNorm();
    const auto before = [&](int a, int b) {
      return std::lexicographical_compare(centres_[a].data(), centres_[a].data() + 3,
                                          centres_[b].data(), centres_[b].data() + 3);
    };
    if (d2 < best_d2 || (d2 == best_d2 && before(id, best))) {
      best_d2 = d2;
      best = id;
    }
  }
  float scan_all(const Eigen::Vector3d& p) const {
    double best_d2 = std::numeric_limits<double>::infinity();
    int best = 0;
    for (int id = 0; id < static_cast<int>(centres_.size()); ++id) consider(p, id, best, best_d2);
    return values_[best];
  }

  double cell_size_m_;
  std::vector<Eigen::Vector3d> centres_;
  std::vector<float> values_;
  std::unordered_map<std::uint64_t, std::vector<int>> buckets_;
};

}  // namespace

std::size_t apply_grid_ao(const MvaoGrid& grid, int mesh_cell_factor, TriangleMesh& mesh) {
  if (mesh_cell_factor > 1) return apply_grid_ao_cells(grid.coarsened(mesh_cell_factor), mesh);
  return apply_grid_ao_cells(grid, mesh);
}

std::size_t apply_grid_ao_cells(const MvaoGrid& grid, TriangleMesh& mesh) {
  const std::size_t n = mesh.vertices.size();
  mesh.quality.assign(n, 1.0f);
  if (n == 0) return 0;
  if (grid.cell_count() == 0) return n;
  std::vector<unsigned char> missed(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto v = grid.sample(mesh.vertices[i].cast<double>());
      if (v && std::isfinite(*v)) {
        mesh.quality[i] = *v;
      } else {
        missed[i] = 1;
      }
    }
  });
  std::size_t fallback = 0;
  for (unsigned char m : missed) fallback += m;
  if (fallback == 0) return 0;
  const NearestCells nearest(grid);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      if (!missed[i]) continue;
      const Eigen::Vector3d p = mesh.vertices[i].cast<double>();
      const float v = p.allFinite() ? nearest.nearest(p) : 1.0f;
      mesh.quality[i] = std::isfinite(v) ? std::min(std::max(v, 0.0f), 1.0f) : 1.0f;
    }
  });
  return fallback;
}

}  // namespace aoscan
