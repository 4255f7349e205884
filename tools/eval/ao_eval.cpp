/// @file ao_eval.cpp
/// @brief Mesh AO against ray-traced obscurance.
#include "ao_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "core/status.h"
#include "sim/reference_ao.h"

namespace aoscan::eval {
namespace {

/// Reference rays start this far (m) above the surface point, along its normal.
constexpr double kRayOffsetM = 1e-5;

/// Where the reference rays of surface point `s` start: kRayOffsetM above it along its normal, and
/// as far off any other face that passes within half that distance. A point on the line where a
/// wall meets a cabinet's side lies in the wall's plane; a ray starting there and leaving the wall
/// would count as starting inside it and read fully occluded.
Eigen::Vector3d ray_origin(const AnalyticScene& scene, const SurfacePoint& s) {
  Eigen::Vector3d origin = s.p + kRayOffsetM * s.normal;
  for (int i = 0; i < 3; ++i) {  // three faces meet at a corner
    const std::optional<SurfacePoint> other =
        scene.nearest_surface_point(origin, 0.5 * kRayOffsetM);
    if (!other) break;
    origin += kRayOffsetM * other->normal;
  }
  return origin;
}

}  // namespace

double scene_obscurance(const AnalyticScene& scene, const RayCaster& cast, const SurfacePoint& s,
                        double t_max_m, int strata) {
  return reference_obscurance(cast, ray_origin(scene, s), s.normal, t_max_m, strata, 0.0);
}

RayCaster scene_ray_caster(const AnalyticScene& scene) {
  return [&scene](const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                  double t_max) -> std::optional<double> {
    Hit hit;
    if (!scene.intersect(Ray{o, d}, 0.0, t_max, &hit)) return std::nullopt;
    return hit.t;
  };
}

AoEvalResult evaluate_mesh_ao(const TriangleMesh& mesh, const AnalyticScene& scene,
                              const Pose& T_scene_mesh, double t_max_m, std::size_t max_vertices,
                              int strata, double max_offset_m) {
  AoEvalResult r;
  if (mesh.vertices.empty() || mesh.quality.size() != mesh.vertices.size()) return r;
  const RayCaster cast = scene_ray_caster(scene);
  const std::size_t step =
      std::max<std::size_t>(1, mesh.vertices.size() / std::max<std::size_t>(max_vertices, 1));
  std::vector<double> mesh_ao, reference;
  for (std::size_t i = 0; i < mesh.vertices.size(); i += step) {
    const std::optional<SurfacePoint> s =
        scene.nearest_surface_point(T_scene_mesh * mesh.vertices[i].cast<double>(), max_offset_m);
    if (!s) {
      ++r.off_surface;
      continue;
    }
    mesh_ao.push_back(mesh.quality[i]);
    reference.push_back(scene_obscurance(scene, cast, *s, t_max_m, strata));
    r.pairs.push_back({s->p, mesh_ao.back(), reference.back()});
  }
  r.vertices = mesh_ao.size();
  if (r.vertices == 0) return r;
  double sq = 0, sm = 0, sr = 0;
  for (std::size_t i = 0; i < r.vertices; ++i) {
    sq += (mesh_ao[i] - reference[i]) * (mesh_ao[i] - reference[i]);
    sm += mesh_ao[i];
    sr += reference[i];
  }
  const auto n = static_cast<double>(r.vertices);
  r.rmse = std::sqrt(sq / n);
  r.mean_mesh = sm / n;
  r.mean_reference = sr / n;
  r.pearson_r = pearson_r(mesh_ao, reference);
  return r;
}

void write_ao_pairs_csv(const std::string& path, const AoEvalResult& result) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw usage_error(path + ": cannot write the AO comparison");
  std::fprintf(f, "x,y,z,mesh_ao,reference\n");
  for (const AoEvalResult::Pair& e : result.pairs)
    std::fprintf(f, "%.5f,%.5f,%.5f,%.5f,%.5f\n", e.p.x(), e.p.y(), e.p.z(), e.mesh_ao,
                 e.reference);
  const bool ok = std::fclose(f) == 0;
  if (!ok) throw usage_error(path + ": cannot write the AO comparison");
}

}  // namespace aoscan::eval
