/// @file colour_eval.h
/// @brief Agreement of a mesh's vertex colours with the exact colour of a synthetic scene.
#pragma once

#include <cstddef>

#include "core/mesh.h"
#include "core/pose.h"
#include "sim/synth_scene.h"

namespace aoscan::eval {

struct ColourEvalResult {
  std::size_t vertices = 0;     ///< vertices compared
  std::size_t off_surface = 0;  ///< vertices skipped: no scene surface within max_offset_m
  /// Mean over the compared vertices of the absolute difference per channel (0-255), the three
  /// channels averaged; and the same without the vertices within `edge_m` of another primitive
  /// (where a vertex's voxels straddle two colours).
  double mean_abs = 0.0;
  double mean_abs_inside = 0.0;
  std::size_t near_edges = 0;  ///< compared vertices within edge_m of another primitive
  double p95_abs = 0.0;        ///< 95th percentile of the per-vertex difference
};

/// Compares `mesh.colours` (mapped into the scene frame by T_scene_mesh) with the colour of the
/// scene's primitive nearest each vertex (AnalyticScene::nearest_surface_point(),
/// AnalyticScene::colour()). Throws usage_error for a mesh without colours.
ColourEvalResult evaluate_mesh_colour(const TriangleMesh& mesh, const AnalyticScene& scene,
                                      const Pose& T_scene_mesh, double max_offset_m = 0.02,
                                      double edge_m = 0.02);

}  // namespace aoscan::eval
