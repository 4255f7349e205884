/// @file colour_eval.cpp
/// @brief Mesh colours against the scene's primitive colours.
#include "colour_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "core/status.h"

namespace aoscan::eval {

ColourEvalResult evaluate_mesh_colour(const TriangleMesh& mesh, const AnalyticScene& scene,
                                      const Pose& T_scene_mesh, double max_offset_m,
                                      double edge_m) {
  if (mesh.colours.size() != mesh.vertices.size() || mesh.vertices.empty())
    throw usage_error("colour evaluation: the mesh has no vertex colours");
  ColourEvalResult r;
  // Each primitive alone, for the distance to it.
  std::vector<AnalyticScene> alone;
  for (const SceneBox& b : scene.boxes()) alone.emplace_back().add_box(b.min, b.max);
  for (const SceneSphere& s : scene.spheres()) alone.emplace_back().add_sphere(s.centre, s.radius);
  std::vector<double> errors;
  double sum_inside = 0.0;
  std::size_t inside = 0;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3d p = T_scene_mesh.rotation() * mesh.vertices[i].cast<double>() +
                              T_scene_mesh.translation();
    const std::optional<SurfacePoint> s = scene.nearest_surface_point(p, max_offset_m);
    if (!s) {
      ++r.off_surface;
      continue;
    }
    const Rgb8 want = scene.colour(s->primitive);
    const Rgb8& got = mesh.colours[i];
    const double e = (std::abs(int{got.r} - int{want.r}) + std::abs(int{got.g} - int{want.g}) +
                      std::abs(int{got.b} - int{want.b})) /
                     3.0;
    errors.push_back(e);
    // Near another primitive's surface of another colour: an edge between colours.
    bool near_edge = false;
    for (int k = 0; k < static_cast<int>(alone.size()); ++k) {
      if (k == s->primitive || scene.colour(k) == want) continue;
      if (alone[static_cast<std::size_t>(k)].distance(s->p) < edge_m) {
        near_edge = true;
        break;
      }
    }
    if (near_edge) {
      ++r.near_edges;
    } else {
      sum_inside += e;
      ++inside;
    }
  }
  r.vertices = errors.size();
  if (errors.empty()) return r;
  double sum = 0.0;
  for (double e : errors) sum += e;
  r.mean_abs = sum / static_cast<double>(errors.size());
  r.mean_abs_inside = inside > 0 ? sum_inside / static_cast<double>(inside) : 0.0;
  std::sort(errors.begin(), errors.end());
  r.p95_abs = errors[static_cast<std::size_t>(0.95 * static_cast<double>(errors.size() - 1))];
  return r;
}

}  // namespace aoscan::eval
