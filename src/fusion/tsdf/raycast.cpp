/// @file raycast.cpp
/// @brief TSDF raycasting: depth-hint search, per-tile depth bounds from the allocated blocks,
/// block skipping, steps by the TSDF value, regula-falsi-refined zero crossings, gradient normals;
/// the portable row loop and the one dispatch to the AVX2 row loop (raycast_avx2.cpp).
#include "fusion/tsdf/raycast.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/status.h"
#include "fusion/tsdf/raycast_kernels.h"
#include "fusion/tsdf/tsdf_sampler.h"
#include "geometry/simd.h"

namespace aoscan {
namespace detail {
namespace {

/// Block groups of the depth-bounds pass; fixed so the split never depends on threads.
constexpr int kBoundsGroups = 16;
/// Limit of the refinement iterations after a zero crossing is bracketed ...
constexpr int kRefineIterations = 4;
/// ... which stop when the bracket is this short (depth along the optical axis, m) or the
/// sample's distance to the surface is below it (m).
constexpr float kRefineTolerance = 1e-4f;

}  // namespace

/// Finds the zero crossing between s0 (tsdf f0 >= 0) and s1 (tsdf f1 < 0) on trilinear samples by
/// the Illinois variant of regula falsi (converges where the field is not linear, e.g. at grazing
/// angles); a bracket within one voxel takes a single secant step.
float refine_crossing(TsdfSampler& sampler, const Ray& ray, float voxel_size, float truncation,
                      float s0, float f0, float s1, float f1) {
  // Within a voxel the interpolated field is close to linear: one secant step is enough.
  if ((s1 - s0) * ray.metres_per_s <= voxel_size) return s0 + (s1 - s0) * f0 / (f0 - f1);
  int side = 0;
  for (int i = 0; i < kRefineIterations; ++i) {
    const float s = s0 + (s1 - s0) * f0 / (f0 - f1);
    float f = 0;
    if (!sampler.trilinear(ray.origin + s * ray.dir, f)) break;
    if (std::abs(f) * truncation < kRefineTolerance) return s;
    if (f > 0) {
      s0 = s;
      f0 = f;
      if (side == 1) f1 *= 0.5f;
      side = 1;
    } else {
      s1 = s;
      f1 = f;
      if (side == -1) f0 *= 0.5f;
      side = -1;
    }
    if (s1 - s0 < kRefineTolerance) break;
  }
  return s0 + (s1 - s0) * f0 / (f0 - f1);
}

void clear_pixel(RaycastResult& r, int x, int y) {
  r.depth_m(x, y) = 0.0f;
  r.maps.vertices(x, y).setZero();
  r.maps.normals(x, y).setZero();
}

/// Writes depth, vertex and normal of a hit at depth s (normal: TSDF gradient by central
/// differences around the nearest voxel, 7 voxel reads); clears the pixel when it is not
/// available.
void write_hit(TsdfSampler& sampler, const Ray& ray, float s, const Eigen::Matrix3f& R_camera_world,
               RaycastResult& r, int x, int y) {
  Eigen::Vector3f grad;
  if (!sampler.nearest_gradient(ray.origin + s * ray.dir, grad) || !(grad.squaredNorm() > 1e-12f)) {
    clear_pixel(r, x, y);
    return;
  }
  const Eigen::Vector3f vertex = ray.ray_camera * s;
  Eigen::Vector3f normal = (R_camera_world * grad).normalized();
  if (normal.dot(vertex) > 0.0f) normal = -normal;
  r.depth_m(x, y) = s;
  r.maps.vertices(x, y) = vertex;
  r.maps.normals(x, y) = normal;
}

void prepare(const Intrinsics& intrinsics, const Pose& T_world_camera, RaycastResult& result) {
  result.T_world_camera = T_world_camera;
  result.maps.intrinsics = intrinsics;
  result.depth_m.resize(intrinsics.width, intrinsics.height, 0.0f);
  result.maps.vertices.resize(intrinsics.width, intrinsics.height, Eigen::Vector3f::Zero());
  result.maps.normals.resize(intrinsics.width, intrinsics.height, Eigen::Vector3f::Zero());
  result.hits = 0;
}

void check_inputs(const Intrinsics& intrinsics, const FusionConfig& config) {
  if (!intrinsics.valid()) throw usage_error("raycast: invalid intrinsics");
  if (!(config.raycast_min_depth_m < config.raycast_max_depth_m))
    throw usage_error("fusion.raycast_min_depth_m must be below fusion.raycast_max_depth_m");
}

namespace {

/// Per-tile [min, max] depth of the allocated blocks' boxes (voxel-centre box [8b, 8b + 8] per
/// axis: every position whose trilinear sample reads that block's lowest voxel). Tiles without a
/// block get min = +inf.
void depth_bounds(const TsdfVolume& volume, const Intrinsics& k, const Pose& T_world_camera,
                  float min_depth, int tiles_x, int tiles_y, std::vector<float>& zmin,
                  std::vector<float>& zmax) {
  const Pose T_camera_world = T_world_camera.inverse();
  const Eigen::Matrix3f R = T_camera_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_camera_world.translation().cast<float>();
  const float vs = volume.voxel_size_m();
  const float fx = static_cast<float>(k.fx), fy = static_cast<float>(k.fy);
  const float cx = static_cast<float>(k.cx), cy = static_cast<float>(k.cy);
  const std::size_t tiles = static_cast<std::size_t>(tiles_x) * tiles_y;
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<std::vector<float>> group_min(kBoundsGroups), group_max(kBoundsGroups);
  const int blocks = volume.block_count();
  // The planes through the camera centre beyond which a point projects off the image (u < 0,
  // u > width - 1, v < 0, v > height - 1), unit normals pointing inwards. A block whose bounding
  // sphere lies wholly behind the near plane or outside one of them adds nothing below (every
  // point it would include falls off the image), so one matrix-vector product rejects it; most
  // blocks of a large model are out of view. The sphere is padded against rounding.
  const float edge = kBlockSize * vs;
  const float radius = 0.5f * std::sqrt(3.0f) * edge * 1.01f + 1e-4f;
  const Eigen::Vector3f side[4] = {
      Eigen::Vector3f(fx, 0.0f, cx).normalized(),
      Eigen::Vector3f(-fx, 0.0f, static_cast<float>(k.width - 1) - cx).normalized(),
      Eigen::Vector3f(0.0f, fy, cy).normalized(),
      Eigen::Vector3f(0.0f, -fy, static_cast<float>(k.height - 1) - cy).normalized()};

  tbb::parallel_for(0, kBoundsGroups, [&](int group) {
    std::vector<float>& gmin = group_min[group];
    std::vector<float>& gmax = group_max[group];
    gmin.assign(tiles, inf);
    gmax.assign(tiles, -inf);
    const int begin = static_cast<int>(static_cast<long long>(blocks) * group / kBoundsGroups);
    const int end = static_cast<int>(static_cast<long long>(blocks) * (group + 1) / kBoundsGroups);
    for (int i = begin; i < end; ++i) {
      const Eigen::Vector3f lo = (volume.block_coord(i) * kBlockSize).cast<float>() * vs;
      const Eigen::Vector3f centre = R * (lo + Eigen::Vector3f::Constant(0.5f * edge)) + t;
      if (centre.z() + radius < min_depth || side[0].dot(centre) < -radius ||
          side[1].dot(centre) < -radius || side[2].dot(centre) < -radius ||
          side[3].dot(centre) < -radius)
        continue;
      float z_lo = inf, z_hi = -inf, u_lo = inf, u_hi = -inf, v_lo = inf, v_hi = -inf;
      Eigen::Vector3f p[8];
      for (int c = 0; c < 8; ++c) {
        p[c] = R * (lo + edge * Eigen::Vector3f(c & 1, (c >> 1) & 1, (c >> 2) & 1)) + t;
        z_lo = std::min(z_lo, p[c].z());
        z_hi = std::max(z_hi, p[c].z());
      }
      if (z_hi < min_depth) continue;
      auto include = [&](const Eigen::Vector3f& q) {
        const float u = fx * q.x() / q.z() + cx;
        const float v = fy * q.y() / q.z() + cy;
        u_lo = std::min(u_lo, u);
        u_hi = std::max(u_hi, u);
        v_lo = std::min(v_lo, v);
        v_hi = std::max(v_hi, v);
      };
      // The box clipped by the near plane z = min_depth: corners in front, and where the box
      // edges cross the plane.
      for (int c = 0; c < 8; ++c) {
        if (p[c].z() >= min_depth) include(p[c]);
        for (int axis = 0; axis < 3; ++axis) {
          const int d = c | (1 << axis);
          if (d == c) continue;
          const float zc = p[c].z() - min_depth, zd = p[d].z() - min_depth;
          if ((zc < 0.0f) != (zd < 0.0f)) include(p[c] + (p[d] - p[c]) * (zc / (zc - zd)));
        }
      }
      if (u_hi < 0.0f || v_hi < 0.0f || u_lo > static_cast<float>(k.width - 1) ||
          v_lo > static_cast<float>(k.height - 1))
        continue;
      const int x0 = std::max(0, static_cast<int>(std::ceil(std::max(u_lo, -1.0f))));
      const int x1 = std::min(k.width - 1, static_cast<int>(std::floor(u_hi)));
      const int y0 = std::max(0, static_cast<int>(std::ceil(std::max(v_lo, -1.0f))));
      const int y1 = std::min(k.height - 1, static_cast<int>(std::floor(v_hi)));
      if (x0 > x1 || y0 > y1) continue;
      z_lo = std::max(z_lo, min_depth);
      for (int ty = y0 / kTile; ty <= y1 / kTile; ++ty) {
        for (int tx = x0 / kTile; tx <= x1 / kTile; ++tx) {
          const std::size_t ti = static_cast<std::size_t>(ty) * tiles_x + tx;
          gmin[ti] = std::min(gmin[ti], z_lo);
          gmax[ti] = std::max(gmax[ti], z_hi);
        }
      }
    }
  });
  zmin.assign(tiles, inf);
  zmax.assign(tiles, -inf);
  for (int group = 0; group < kBoundsGroups; ++group) {
    for (std::size_t ti = 0; ti < tiles; ++ti) {
      zmin[ti] = std::min(zmin[ti], group_min[group][ti]);
      zmax[ti] = std::max(zmax[ti], group_max[group][ti]);
    }
  }
}

}  // namespace

/// True when every ray position stays far inside the int range of voxel coordinates.
bool within_grid(const TsdfVolume& volume, const Intrinsics& k, const Pose& T_world_camera,
                 const FusionConfig& config) {
  const double rx = std::max(std::abs(k.cx), std::abs(k.width - k.cx)) / k.fx;
  const double ry = std::max(std::abs(k.cy), std::abs(k.height - k.cy)) / k.fy;
  const double reach = T_world_camera.translation().cwiseAbs().maxCoeff() +
                       std::sqrt(1.0 + rx * rx + ry * ry) * config.raycast_max_depth_m;
  return reach / volume.voxel_size_m() < static_cast<double>(1 << 23);
}

namespace {

/// Looks for a + to - crossing of the trilinear field between depths s0 and s1 in steps of half
/// a voxel; writes the hit and returns true when it finds one (and the hit has a normal).
bool scan_crossing(TsdfSampler& sampler, const Ray& ray, float s0, float s1, float voxel_size,
                   float truncation, const Eigen::Matrix3f& R_camera_world, RaycastResult& result,
                   int x, int y) {
  const float step = 0.5f * voxel_size / ray.metres_per_s;
  float fa = 0.0f;
  bool va = sampler.trilinear(ray.origin + s0 * ray.dir, fa);
  float sa = s0;
  for (float sb = s0 + step; sb < s1 + step; sb += step) {
    float fb = 0.0f;
    const bool vb = sampler.trilinear(ray.origin + sb * ray.dir, fb);
    if (va && vb && fa >= 0.0f && fb < 0.0f) {
      write_hit(sampler, ray, refine_crossing(sampler, ray, voxel_size, truncation, sa, fa, sb, fb),
                R_camera_world, result, x, y);
      return result.depth_m(x, y) > 0.0f;
    }
    sa = sb;
    fa = fb;
    va = vb;
  }
  return false;
}

}  // namespace

/// Marches one ray from depth s to s_end; writes the pixel and returns true on a surface hit.
bool march(TsdfSampler& sampler, const Ray& ray, float s, float s_end, float voxel_size,
           float truncation, const Eigen::Matrix3f& R_camera_world, RaycastResult& result, int x,
           int y) {
  const float s_per_metre = 1.0f / ray.metres_per_s;
  const float min_step = voxel_size * s_per_metre;
  const float big_step = 0.8f * truncation * s_per_metre;
  float prev_s = 0.0f, prev_f = 0.0f;
  bool prev_valid = false;
  while (s < s_end) {
    // Steps read the nearest voxel only (one cache line); trilinear samples are taken once a
    // sign change is bracketed.
    const Eigen::Vector3f g = ray.origin + s * ray.dir;
    const int gx = floor_to_int(g.x() + 0.5f);
    const int gy = floor_to_int(g.y() + 0.5f);
    const int gz = floor_to_int(g.z() + 0.5f);
    const Voxel* v = sampler.voxel(gx, gy, gz);
    if (v == nullptr) {
      // Jump to where the ray leaves the space whose nearest voxel is in this unallocated
      // block, [8b - 0.5, 8b + 7.5) per axis, or in this empty region of blocks.
      constexpr int kBlockShift = 3;   // log2(kBlockSize)
      constexpr int kRegionShift = 5;  // log2(kBlockSize * TsdfVolume::kRegionBlocks)
      static_assert(kBlockSize == 1 << kBlockShift);
      static_assert(kBlockSize * TsdfVolume::kRegionBlocks == 1 << kRegionShift);
      const int shift =
          sampler.region_empty(gx >> kRegionShift, gy >> kRegionShift, gz >> kRegionShift)
              ? kRegionShift
              : kBlockShift;
      float s_exit = std::numeric_limits<float>::infinity();
      const int b[3] = {gx >> shift, gy >> shift, gz >> shift};
      for (int a = 0; a < 3; ++a) {
        if (ray.dir[a] == 0.0f) continue;
        const float boundary =
            static_cast<float>((ray.dir[a] > 0.0f ? b[a] + 1 : b[a]) * (1 << shift)) - 0.5f;
        s_exit = std::min(s_exit, (boundary - ray.origin[a]) / ray.dir[a]);
      }
      s = std::max(s_exit, s) + 0.01f * min_step;
      prev_valid = false;
      continue;
    }
    if (v->count == 0) {
      // Unobserved voxels carry no surface; a step under the truncation cannot jump over the
      // positive band in front of an observed one.
      prev_valid = false;
      s += big_step;
      continue;
    }
    const float f = v->tsdf();
    if (prev_valid && prev_f >= 0.0f && f < 0.0f) {
      float f0 = 0.0f, f1 = 0.0f;
      bool ok0 = sampler.trilinear(ray.origin + prev_s * ray.dir, f0);
      const bool ok1 = sampler.trilinear(g, f1);
      // Nearest and interpolated values can disagree within a voxel of the surface: when the
      // interpolated field has already crossed at prev_s, back up to where it has not.
      for (int back = 1; back <= 2 && ok0 && ok1 && f0 < 0.0f && f1 < 0.0f; ++back) {
        prev_s -= min_step;
        ok0 = sampler.trilinear(ray.origin + prev_s * ray.dir, f0);
      }
      if (ok0 && ok1 && f0 >= 0.0f && f1 < 0.0f) {
        write_hit(sampler, ray,
                  refine_crossing(sampler, ray, voxel_size, truncation, prev_s, f0, s, f1),
                  R_camera_world, result, x, y);
        return result.depth_m(x, y) > 0.0f;
      }
      if (ok1 && f1 >= 0.0f) {
        // The interpolated field has not crossed yet: creep on.
        prev_s = s;
        prev_f = std::max(f1, 1e-6f);
        s += min_step;
        continue;
      }
      // A trilinear cell at one end reaches unobserved voxels (the negative band behind a
      // surface is only a truncation thick along the view that saw it): look for the crossing
      // between the two samples in half-voxel steps.
      if (scan_crossing(sampler, ray, prev_s, s, voxel_size, truncation, R_camera_world, result, x,
                        y))
        return true;
    }
    prev_s = s;
    prev_f = f;
    prev_valid = true;
    s += f > 0.0f ? std::max(min_step, f * truncation * s_per_metre) : min_step;
  }
  return false;
}
namespace {

/// Searches for the surface around depth `d` (a depth measured at this pixel and pose): walks
/// from d towards the zero of the trilinear field in steps of its value (at least a voxel) until
/// the sign changes. Returns false when the field is unavailable or no sign change is found
/// within kHintSteps steps; the caller then marches the window around d (finish_hinted_ray()).
bool search_near(TsdfSampler& sampler, const Ray& ray, float d, float s_begin, float s_end,
                 float voxel_size, float truncation, Bracket& out) {
  const float s_per_metre = 1.0f / ray.metres_per_s;
  const float min_step = voxel_size * s_per_metre;
  float s_a = d, f_a = 0.0f;
  if (!(s_a >= s_begin && s_a < s_end) || !sampler.trilinear(ray.origin + s_a * ray.dir, f_a))
    return false;
  const float direction = f_a >= 0.0f ? 1.0f : -1.0f;
  for (int i = 0; i < kHintSteps; ++i) {
    // Aim half a voxel past the estimated zero so that one step usually brackets it.
    const float s_b =
        s_a + direction * (std::abs(f_a) * truncation * s_per_metre + 0.5f * min_step);
    float f_b = 0.0f;
    if (!(s_b >= s_begin && s_b < s_end) || !sampler.trilinear(ray.origin + s_b * ray.dir, f_b))
      return false;
    if ((f_b >= 0.0f) != (f_a >= 0.0f)) {
      const bool forward = direction > 0.0f;
      out = forward ? Bracket{s_a, f_a, s_b, f_b} : Bracket{s_b, f_b, s_a, f_a};
      return true;
    }
    s_a = s_b;
    f_a = f_b;
  }
  return false;
}
}  // namespace

/// Runs a hinted ray to its end: the refined hit of its bracket (`found`), else, or when the hit
/// has no normal, a march of the window around the hint.
void finish_hinted_ray(TsdfSampler& sampler, const Ray& ray, int x, int y, float d, float s_begin,
                       float s_end, bool found, const Bracket& b, float vs, float trunc,
                       const Eigen::Matrix3f& R_camera_world, RaycastResult& result) {
  if (found) {
    write_hit(sampler, ray, refine_crossing(sampler, ray, vs, trunc, b.s0, b.f0, b.s1, b.f1),
              R_camera_world, result, x, y);
    if (result.depth_m(x, y) > 0.0f) return;
  }
  march(sampler, ray, std::max(s_begin, d - kHintWindow * trunc),
        std::min(s_end, d + kHintWindow * trunc), vs, trunc, R_camera_world, result, x, y);
}
}  // namespace detail

namespace {

using detail::Bracket;
using detail::Ray;
using detail::RaySetup;
using detail::RaycastRows;

/// Raycasts row y one ray at a time.
void raycast_row_portable(TsdfSampler& sampler, const RaycastRows& rows, int y) {
  const RaySetup& setup = rows.setup;
  for (int x = 0; x < rows.width; ++x) {
    Ray ray;
    float s_begin, s_end, d;
    if (!rows.pixel(x, y, ray, s_begin, s_end, d)) continue;
    if (detail::usable_hint(d)) {
      // The frame saw this pixel's surface at depth d and free space in front of it: the model's
      // first crossing is next to d, or the model is unsure here.
      Bracket b;
      const bool found = detail::search_near(sampler, ray, d, s_begin, s_end, rows.voxel_size,
                                             rows.truncation, b);
      detail::finish_hinted_ray(sampler, ray, x, y, d, s_begin, s_end, found, b, rows.voxel_size,
                                rows.truncation, setup.R_camera_world, rows.result);
      continue;
    }
    if (rows.hinted_only) continue;
    detail::march(sampler, ray, s_begin, s_end, rows.voxel_size, rows.truncation,
                  setup.R_camera_world, rows.result, x, y);
  }
}

/// raycast() with the AVX2 row loop (`simd`, the caller checked the CPU) or the portable one.
void raycast_impl(const TsdfVolume& volume, const Intrinsics& intrinsics,
                  const Pose& T_world_camera, const FusionConfig& config, RaycastResult& result,
                  const Image<float>* depth_hint_m, RaycastRays rays, bool simd) {
  detail::check_inputs(intrinsics, config);
  if (depth_hint_m != nullptr &&
      (depth_hint_m->width() != intrinsics.width || depth_hint_m->height() != intrinsics.height))
    throw usage_error("raycast: the depth hint differs in size from the intrinsics");
  detail::prepare(intrinsics, T_world_camera, result);
  if (!T_world_camera.finite() || volume.block_count() == 0 ||
      !detail::within_grid(volume, intrinsics, T_world_camera, config))
    return;

  const float min_depth = static_cast<float>(config.raycast_min_depth_m);
  const float max_depth = static_cast<float>(config.raycast_max_depth_m);
  const int tiles_x = (intrinsics.width + detail::kTile - 1) / detail::kTile;
  const int tiles_y = (intrinsics.height + detail::kTile - 1) / detail::kTile;
  std::vector<float> zmin, zmax;
  detail::depth_bounds(volume, intrinsics, T_world_camera, min_depth, tiles_x, tiles_y, zmin,
                       zmax);

  const RaySetup setup(volume, intrinsics, T_world_camera);
  const RaycastRows rows{setup,
                         depth_hint_m,
                         depth_hint_m != nullptr && rays == RaycastRays::kHintedOnly,
                         zmin.data(),
                         zmax.data(),
                         tiles_x,
                         intrinsics.width,
                         min_depth,
                         max_depth,
                         volume.voxel_size_m(),
                         volume.truncation_m(),
                         result};
  // On a CPU with AVX2 the hinted rays of a row are searched eight per vector.
#if defined(AOSCAN_RAYCAST_AVX2)
  const auto raycast_row = simd ? detail::raycast_row_avx2 : raycast_row_portable;
#else
  static_cast<void>(simd);
  const auto raycast_row = raycast_row_portable;
#endif
  tbb::parallel_for(tbb::blocked_range<int>(0, intrinsics.height, 4),
                    [&](const tbb::blocked_range<int>& range) {
                      TsdfSampler sampler(volume);
                      for (int y = range.begin(); y != range.end(); ++y)
                        raycast_row(sampler, rows, y);
                    });
  result.hits = count_hits(result.depth_m);
}

}  // namespace

int count_hits(const Image<float>& depth) {
  int hits = 0;
  for (std::size_t i = 0; i < depth.size(); ++i) hits += depth.data()[i] > 0.0f ? 1 : 0;
  return hits;
}

void raycast(const TsdfVolume& volume, const Intrinsics& intrinsics, const Pose& T_world_camera,
             const FusionConfig& config, RaycastResult& result, const Image<float>* depth_hint_m,
             RaycastRays rays) {
#if defined(AOSCAN_RAYCAST_AVX2)
  const bool simd = cpu_has_avx2();
#else
  const bool simd = false;
#endif
  raycast_impl(volume, intrinsics, T_world_camera, config, result, depth_hint_m, rays, simd);
}

void raycast_portable(const TsdfVolume& volume, const Intrinsics& intrinsics,
                      const Pose& T_world_camera, const FusionConfig& config, RaycastResult& result,
                      const Image<float>* depth_hint_m, RaycastRays rays) {
  raycast_impl(volume, intrinsics, T_world_camera, config, result, depth_hint_m, rays, false);
}

}  // namespace aoscan
