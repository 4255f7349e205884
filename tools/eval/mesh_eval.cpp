/// @file mesh_eval.cpp
/// @brief Point-to-mesh distances and the accuracy / completeness figures.
#include "mesh_eval.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace aoscan::eval {

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = va + vb + vc;
  if (denom <= 0) return a;  // degenerate triangle
  return a + ab * (vb / denom) + ac * (vc / denom);
}

MeshDistance::MeshDistance(const TriangleMesh& mesh, double cell_m) : cell_m_(cell_m) {
  for (const Eigen::Vector3i& f : mesh.faces) {
    const auto index = static_cast<std::uint32_t>(a_.size());
    a_.push_back(mesh.vertices[f[0]].cast<double>());
    b_.push_back(mesh.vertices[f[1]].cast<double>());
    c_.push_back(mesh.vertices[f[2]].cast<double>());
    const Eigen::Vector3d lo = a_.back().cwiseMin(b_.back()).cwiseMin(c_.back());
    const Eigen::Vector3d hi = a_.back().cwiseMax(b_.back()).cwiseMax(c_.back());
    const Eigen::Vector3i c0 = cell_of(lo), c1 = cell_of(hi);
    for (int z = c0.z(); z <= c1.z(); ++z)
      for (int y = c0.y(); y <= c1.y(); ++y)
        for (int x = c0.x(); x <= c1.x(); ++x) cells_[key({x, y, z})].push_back(index);
  }
}

MeshDistance::Key MeshDistance::key(const Eigen::Vector3i& c) const {
  constexpr std::int64_t kOffset = 1 << 20;
  return ((c.x() + kOffset) << 42) | ((c.y() + kOffset) << 21) | (c.z() + kOffset);
}

Eigen::Vector3i MeshDistance::cell_of(const Eigen::Vector3d& p) const {
  return (p / cell_m_).array().floor().cast<int>();
}

double MeshDistance::distance(const Eigen::Vector3d& p, double max_m) const {
  const Eigen::Vector3i centre = cell_of(p);
  const int max_ring = static_cast<int>(std::ceil(max_m / cell_m_)) + 1;
  double best_sq = max_m * max_m;
  for (int ring = 0; ring <= max_ring; ++ring) {
    // Visit the shell of cells at Chebyshev distance `ring` from the centre cell.
    for (int dz = -ring; dz <= ring; ++dz)
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dx = -ring; dx <= ring; ++dx) {
          if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != ring) continue;
          const auto it = cells_.find(key(centre + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (std::uint32_t t : it->second)
            best_sq = std::min(best_sq, (closest_point_on_triangle(p, a_[t], b_[t], c_[t]) - p).squaredNorm());
        }
    // Every triangle within ring * cell of p touches a visited cell.
    if (best_sq <= std::pow(ring * cell_m_, 2)) break;
  }
  return std::sqrt(best_sq);
}

MeshEvalResult evaluate_mesh(const TriangleMesh& reconstruction, const TriangleMesh& truth,
                             const Pose& T_truth_reconstruction, double max_distance_m,
                             double completeness_threshold_m, std::size_t samples) {
  MeshEvalResult r;
  TriangleMesh moved = reconstruction;
  for (Eigen::Vector3f& v : moved.vertices)
    v = (T_truth_reconstruction * v.cast<double>()).cast<float>();

  const MeshDistance to_truth(truth);
  std::vector<double> d;
  d.reserve(moved.vertices.size());
  std::size_t outliers = 0;
  for (const Eigen::Vector3f& v : moved.vertices) {
    d.push_back(to_truth.distance(v.cast<double>(), max_distance_m));
    if (d.back() >= max_distance_m) ++outliers;
  }
  r.vertices = d.size();
  if (!d.empty()) {
    double sum = 0;
    for (double x : d) sum += x;
    r.accuracy_mean_m = sum / static_cast<double>(d.size());
    std::sort(d.begin(), d.end());
    r.accuracy_median_m = d[d.size() / 2];
    r.accuracy_p90_m = d[std::min(d.size() - 1, d.size() * 9 / 10)];
    r.outlier_fraction = static_cast<double>(outliers) / static_cast<double>(d.size());
  }

  // Area-uniform samples on the true surface.
  std::vector<double> cumulative_area;
  double total = 0;
  for (const Eigen::Vector3i& f : truth.faces) {
    const Eigen::Vector3d a = truth.vertices[f[0]].cast<double>(), b = truth.vertices[f[1]].cast<double>(),
                          c = truth.vertices[f[2]].cast<double>();
    total += 0.5 * (b - a).cross(c - a).norm();
    cumulative_area.push_back(total);
  }
  if (total <= 0 || moved.faces.empty()) return r;
  const MeshDistance to_reconstruction(moved);
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::size_t covered = 0;
  for (std::size_t i = 0; i < samples; ++i) {
    const double pick = uniform(rng) * total;
    const auto face = static_cast<std::size_t>(
        std::lower_bound(cumulative_area.begin(), cumulative_area.end(), pick) - cumulative_area.begin());
    const Eigen::Vector3i& f = truth.faces[std::min(face, truth.faces.size() - 1)];
    double u = uniform(rng), v = uniform(rng);
    if (u + v > 1) {
      u = 1 - u;
      v = 1 - v;
    }
    const Eigen::Vector3d a = truth.vertices[f[0]].cast<double>();
    const Eigen::Vector3d p = a + u * (truth.vertices[f[1]].cast<double>() - a) +
                              v * (truth.vertices[f[2]].cast<double>() - a);
    if (to_reconstruction.distance(p, completeness_threshold_m) < completeness_threshold_m) ++covered;
  }
  r.truth_samples = samples;
  r.completeness = static_cast<double>(covered) / static_cast<double>(samples);
  return r;
}

}  // namespace aoscan::eval
