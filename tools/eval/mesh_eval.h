/// @file mesh_eval.h
/// @brief Accuracy and completeness of a reconstructed mesh against a ground-truth mesh.
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "core/mesh.h"
#include "core/pose.h"

namespace aoscan::eval {

/// Closest point on triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Exact point-to-mesh distance accelerated by a uniform grid of triangle bounding boxes.
class MeshDistance {
 public:
  explicit MeshDistance(const TriangleMesh& mesh, double cell_m = 0.05);
  /// Distance from p to the nearest triangle; `max_m` when nothing is within max_m.
  double distance(const Eigen::Vector3d& p, double max_m) const;

 private:
  using Key = std::int64_t;
  Key key(const Eigen::Vector3i& cell) const;
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const;

  double cell_m_;
  std::vector<Eigen::Vector3d> a_, b_, c_;
  std::unordered_map<Key, std::vector<std::uint32_t>> cells_;
};

struct MeshEvalResult {
  std::size_t vertices = 0;         ///< reconstructed vertices evaluated
  double accuracy_mean_m = 0;       ///< mean distance of reconstructed vertices to the truth
  double accuracy_median_m = 0;
  double accuracy_p90_m = 0;
  double outlier_fraction = 0;      ///< vertices farther than max_distance_m (capped in the mean)
  std::size_t truth_samples = 0;    ///< points sampled on the true surface
  double completeness = 0;          ///< fraction of those within completeness_threshold_m
};

/// Compares `reconstruction` (mapped into the truth's frame by T_truth_reconstruction) with
/// `truth`. Accuracy: reconstructed vertex → true surface distances, each capped at
/// max_distance_m. Completeness: `samples` area-uniform points on the true surface (fixed seed)
/// that have reconstructed surface within completeness_threshold_m. Surfaces the camera never saw
/// count as incomplete.
MeshEvalResult evaluate_mesh(const TriangleMesh& reconstruction, const TriangleMesh& truth,
                             const Pose& T_truth_reconstruction, double max_distance_m = 0.1,
                             double completeness_threshold_m = 0.01, std::size_t samples = 200000);

}  // namespace aoscan::eval
