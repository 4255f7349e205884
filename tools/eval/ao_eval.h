/// @file ao_eval.h
/// @brief Agreement of a mesh's per-vertex AO with ray-traced obscurance (Sabbadin et al. 2016 Eq.
/// 1) on the exact geometry of a synthetic scene.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/mesh.h"
#include "core/pose.h"
#include "sim/reference_ao.h"
#include "sim/synth_scene.h"

namespace aoscan::eval {

struct AoEvalResult {
  std::size_t vertices = 0;     ///< vertices compared
  std::size_t off_surface = 0;  ///< sampled vertices skipped: no surface point within max_offset_m
                                ///< (AnalyticScene::nearest_surface_point())
  double pearson_r = 0;         ///< correlation of mesh AO with the reference
  double rmse = 0;              ///< root-mean-square difference
  double mean_mesh = 0, mean_reference = 0;
  /// Per compared vertex: its scene point (scene frame, m), the mesh AO and the reference AO.
  struct Pair {
    Eigen::Vector3d p;
    double mesh_ao, reference;
  };
  std::vector<Pair> pairs;
};

/// Pearson r of `mesh.quality` against Eq. 1 obscurance (rho = smoothstep(0, t_max, d), 1 without
/// a hit within t_max, strata^2 cosine-weighted rays) at the scene point nearest each vertex, with
/// the scene's exact normal there (AnalyticScene::nearest_surface_point()). Vertices are mapped
/// into the scene frame by T_scene_mesh; at most max_vertices of them, evenly spread over the
/// vertex list, are compared.
AoEvalResult evaluate_mesh_ao(const TriangleMesh& mesh, const AnalyticScene& scene,
                              const Pose& T_scene_mesh, double t_max_m,
                              std::size_t max_vertices = 20000, int strata = 16,
                              double max_offset_m = 0.02);

/// The reference's ray caster over `scene` (which must outlive it): the first hit from t = 0.
RayCaster scene_ray_caster(const AnalyticScene& scene);

/// Eq. 1 obscurance (reference_obscurance()) at surface point `s` of `scene`, `cast` being
/// scene_ray_caster(scene): its rays start just above the point along its normal, and as far off
/// any other face passing that close (a point on the line where a wall meets a cabinet's side lies
/// in the wall's plane too).
double scene_obscurance(const AnalyticScene& scene, const RayCaster& cast, const SurfacePoint& s,
                        double t_max_m, int strata);

/// Writes `result.pairs` as CSV with the header `x,y,z,mesh_ao,reference`; a file that cannot be
/// written is a usage_error naming it.
void write_ao_pairs_csv(const std::string& path, const AoEvalResult& result);

}  // namespace aoscan::eval
