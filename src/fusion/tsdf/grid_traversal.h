/// @file grid_traversal.h
/// @brief The cells of a unit grid that a segment crosses, in order along it: the block
/// allocation of the TSDF's truncation band walks one short segment per depth pixel.
#pragma once

#include <cmath>
#include <limits>

#include <Eigen/Core>

namespace aoscan {

/// The order in which a segment a-b crosses the cell boundaries between ia = floor(a) and
/// ib = floor(b) when they differ by at most one per axis: rank[i] = how many of the segment's
/// crossings come before axis i's (ties: the lower axis first; axes that do not move get a rank
/// they never reach). Axis i crosses the plane p_i between its two cells at t_i = (p_i - a_i) /
/// (b_i - a_i), compared as num_i / den_i with both >= 0 by cross-multiplying, without a
/// division (den_i > 0: a_i and b_i lie in different cells).
inline void short_path_ranks(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                             const Eigen::Vector3i& ia, const Eigen::Vector3i& ib, int* rank) {
  const Eigen::Vector3i delta = ib - ia;
  float num[3], den[3];
  for (int i = 0; i < 3; ++i) {
    const float sign = static_cast<float>(delta[i]);
    const float plane = static_cast<float>(delta[i] > 0 ? ib[i] : ia[i]);
    num[i] = (plane - a[i]) * sign;
    den[i] = delta[i] != 0 ? (b[i] - a[i]) * sign : 1.0f;
  }
  const auto before = [&](int i, int j) {  // axis i crosses before axis j
    if (delta[i] == 0) return false;
    if (delta[j] == 0) return true;
    const float ti = num[i] * den[j], tj = num[j] * den[i];
    return i < j ? ti <= tj : ti < tj;
  };
  rank[0] = before(1, 0) + before(2, 0);
  rank[1] = before(0, 1) + before(2, 1);
  rank[2] = before(0, 2) + before(1, 2);
}

/// Calls emit(cell) for the cells after ia of the short path with these ranks: the k-th has
/// moved from ia along the axes of rank < k.
template <class Emit>
inline void emit_short_path(const Eigen::Vector3i& ia, const Eigen::Vector3i& ib, const int* rank,
                            Emit&& emit) {
  const Eigen::Vector3i delta = ib - ia;
  const int n = (delta[0] != 0) + (delta[1] != 0) + (delta[2] != 0);
  Eigen::Vector3i cur;
  for (int k = 1; k <= n; ++k) {
    for (int i = 0; i < 3; ++i) cur[i] = ia[i] + (rank[i] < k ? delta[i] : 0);
    emit(static_cast<const Eigen::Vector3i&>(cur));
  }
}

/// Calls emit(cell) for every cell of the unit grid (cell c covers [c, c + 1) per axis) that the
/// segment a-b crosses, from ia = floor(a) to ib = floor(b) in the order the segment enters
/// them: |ib - ia|_1 + 1 face-connected cells, each step along the axis whose next cell
/// boundary the segment reaches first (Amanatides and Woo 1987). Ties go to the lower axis.
/// `ia` and `ib` must be the floors of `a` and `b`.
///
/// Most segments of the band are about one cell long and differ from their first cell by at
/// most one cell per axis: short_path_ranks() orders their crossings without a division.
/// Longer segments take the incremental traversal with one reciprocal per moving axis. Every
/// step goes along an axis that still has cells to go, so the walk always ends at ib, rounding
/// or not.
template <class Emit>
inline void traverse_cells(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                           const Eigen::Vector3i& ia, const Eigen::Vector3i& ib, Emit&& emit) {
  const Eigen::Vector3i delta = ib - ia;
  emit(ia);
  if (delta.cwiseAbs().maxCoeff() <= 1) {
    int rank[3];
    short_path_ranks(a, b, ia, ib, rank);
    emit_short_path(ia, ib, rank, emit);
    return;
  }
  const Eigen::Vector3f dir = b - a;
  Eigen::Vector3i cur = ia;
  Eigen::Vector3i remaining;
  Eigen::Vector3f t_max, t_delta;
  for (int i = 0; i < 3; ++i) {
    remaining[i] = std::abs(delta[i]);
    if (delta[i] == 0) {
      t_max[i] = t_delta[i] = std::numeric_limits<float>::infinity();
      continue;
    }
    const float inv = 1.0f / dir[i];
    const float boundary = static_cast<float>(cur[i] + (delta[i] > 0 ? 1 : 0));
    t_max[i] = (boundary - a[i]) * inv;
    t_delta[i] = std::abs(inv);
  }
  for (int steps = remaining.sum(); steps > 0; --steps) {
    int axis = -1;
    for (int i = 0; i < 3; ++i)
      if (remaining[i] > 0 && (axis < 0 || t_max[i] < t_max[axis])) axis = i;
    cur[axis] += delta[axis] > 0 ? 1 : -1;
    --remaining[axis];
    t_max[axis] += t_delta[axis];
    emit(static_cast<const Eigen::Vector3i&>(cur));
  }
}

}  // namespace aoscan
