/// @file icp.cpp
/// @brief Projective point-to-plane ICP: per-pixel association and Huber-weighted normal
/// equations reduced deterministically, degeneracy-aware Gauss-Newton steps, tracking status.
#include "fusion/tracking/icp.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#if defined(__x86_64__)
#include <immintrin.h>
#endif
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "core/status.h"
#include "geometry/normal_smoothing.h"
#include "geometry/simd.h"

namespace aoscan {
namespace {

// The fast paths read vertex and normal maps as packed x, y, z floats.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");

/// Image rows reduced by one task; fixed so the summation order never depends on threads.
constexpr int kRowsPerGroup = 4;
/// Fewer inliers than this at full resolution: lost, whatever the ratio.
constexpr int kMinInliers = 64;
/// Eigenvalues of the system below this fraction of the largest are unconstrained (rounding):
/// such a direction takes the prior's increment alone.
constexpr double kDegenerateEigenRatio = 1e-6;
/// Increments below these (rad, m) end a level early (0.006 degrees, 0.05 mm).
constexpr double kConvergedRotation = 1e-4;
constexpr double kConvergedTranslation = 5e-5;

/// Partial sums of the normal equations (upper triangle of A row by row, b, residuals) in
/// scalar type T: float for one image row (a few hundred terms; twice the SIMD width), double
/// for everything summed from rows.
template <typename T>
struct Accumulator {
  T a[21] = {};
  T b[6] = {};
  T residual_sq = 0;
  int inliers = 0;
  int valid = 0;

  void add(const T j[6], T r, T w) {
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      const T wj = w * j[i];
      for (int c = i; c < 6; ++c) a[k++] += wj * j[c];
      b[i] += wj * r;
    }
    residual_sq += r * r;
    ++inliers;
  }
  template <typename U>
  void add(const Accumulator<U>& o) {
    for (int i = 0; i < 21; ++i) a[i] += static_cast<T>(o.a[i]);
    for (int i = 0; i < 6; ++i) b[i] += static_cast<T>(o.b[i]);
    residual_sq += static_cast<T>(o.residual_sq);
    inliers += o.inliers;
    valid += o.valid;
  }
  IcpSystem system() const {
    IcpSystem s;
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      for (int c = i; c < 6; ++c) {
        s.A(i, c) = static_cast<double>(a[k]);
        s.A(c, i) = static_cast<double>(a[k]);
        ++k;
      }
      s.b[i] = static_cast<double>(b[i]);
    }
    s.residual_sq = static_cast<double>(residual_sq);
    s.inliers = inliers;
    s.valid = valid;
    return s;
  }
};

/// Everything the per-pixel association needs, in float, with the arithmetic spelled out so the
/// scalar and the AVX2 paths perform the same IEEE operations in the same order (no fused
/// multiply-adds in the association): both pick exactly the same correspondences.
struct Associator {
  float rot[9];  ///< R_model_camera, row-major
  float t[3];    ///< t_model_camera (m)
  float fx, fy, cx, cy;
  float max_u, max_v;
  float max_distance_sq;
  float min_normal_cos;
  float huber;
  float inv_noise_depth_sq;  ///< 1 / noise_reference_depth_m^2 (1/m^2), 0 without depth weighting
  const float* model_vertices;  ///< model vertex map as x, y, z floats, row-major
  const float* model_normals;
  int model_width;
  int model_last;  ///< float index of the model's last pixel

  Associator(const PointMaps& model_maps, const Pose& T_model_camera, const TrackingConfig& config)
      : fx(static_cast<float>(model_maps.intrinsics.fx)),
        fy(static_cast<float>(model_maps.intrinsics.fy)),
        cx(static_cast<float>(model_maps.intrinsics.cx)),
        cy(static_cast<float>(model_maps.intrinsics.cy)),
        max_u(static_cast<float>(model_maps.vertices.width()) - 0.5f),
        max_v(static_cast<float>(model_maps.vertices.height()) - 0.5f),
        max_distance_sq(static_cast<float>(config.max_distance_m * config.max_distance_m)),
        min_normal_cos(static_cast<float>(std::cos(config.max_normal_angle_deg * M_PI / 180.0))),
        huber(static_cast<float>(config.huber_delta_m)),
        inv_noise_depth_sq(config.noise_reference_depth_m > 0.0
                               ? static_cast<float>(1.0 / (config.noise_reference_depth_m *
                                                           config.noise_reference_depth_m))
                               : 0.0f),
        model_vertices(reinterpret_cast<const float*>(model_maps.vertices.data())),
        model_normals(reinterpret_cast<const float*>(model_maps.normals.data())),
        model_width(model_maps.vertices.width()),
        model_last(3 * (model_maps.vertices.width() * model_maps.vertices.height() - 1)) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        rot[3 * i + j] = static_cast<float>(T_model_camera.rotation()(i, j));
      t[i] = static_cast<float>(T_model_camera.translation()[i]);
    }
  }

  /// Adds the correspondence of the frame pixel with vertex `v` and normal `n` (x, y, z floats),
  /// if any, in T arithmetic.
  template <typename T>
  AOSCAN_NO_CONTRACT void pixel(const float* v, const float* n, Accumulator<T>& acc) const {
    if (!(v[2] > 0.0f) || (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f)) return;
    ++acc.valid;
    const float px = rot[0] * v[0] + rot[1] * v[1] + rot[2] * v[2] + t[0];
    const float py = rot[3] * v[0] + rot[4] * v[1] + rot[5] * v[2] + t[1];
    const float pz = rot[6] * v[0] + rot[7] * v[1] + rot[8] * v[2] + t[2];
    if (!(pz > 0.0f)) return;
    const float u = fx * px / pz + cx;
    const float w = fy * py / pz + cy;
    if (!(u >= -0.5f && w >= -0.5f && u < max_u && w < max_v)) return;
    const int index = 3 * (static_cast<int>(w + 0.5f) * model_width + static_cast<int>(u + 0.5f));
    const float* q = model_vertices + index;
    const float* nm = model_normals + index;
    if (!(q[2] > 0.0f) || (nm[0] == 0.0f && nm[1] == 0.0f && nm[2] == 0.0f)) return;
    const float dx = px - q[0];
    const float dy = py - q[1];
    const float dz = pz - q[2];
    if (!(dx * dx + dy * dy + dz * dz <= max_distance_sq)) return;
    const float rnx = rot[0] * n[0] + rot[1] * n[1] + rot[2] * n[2];
    const float rny = rot[3] * n[0] + rot[4] * n[1] + rot[5] * n[2];
    const float rnz = rot[6] * n[0] + rot[7] * n[1] + rot[8] * n[2];
    if (!(rnx * nm[0] + rny * nm[1] + rnz * nm[2] >= min_normal_cos)) return;
    const float r = nm[0] * dx + nm[1] * dy + nm[2] * dz;
    const T j[6] = {py * nm[2] - pz * nm[1],
                    pz * nm[0] - px * nm[2],
                    px * nm[1] - py * nm[0],
                    nm[0],
                    nm[1],
                    nm[2]};
    // Depth noise scale s = max(1, (z / z_ref)^2): Huber on r / s, weight 1 / s^2 on top.
    const float abs_r = std::abs(r);
    const float noise = std::max(1.0f, pz * pz * inv_noise_depth_sq);
    const float huber_scaled = huber * noise;
    const T weight =
        (abs_r <= huber_scaled ? T(1) : static_cast<T>(huber_scaled) / static_cast<T>(abs_r)) /
        static_cast<T>(noise * noise);
    acc.add(j, static_cast<T>(r), weight);
  }

  /// Frame pixels x0, x0 + step, ... < width of one row (x, y, z floats per pixel).
  AOSCAN_NO_CONTRACT void row_portable(const float* vertices, const float* normals, int x0,
                                       int width, int step, Accumulator<float>& acc) const {
    for (int x = x0; x < width; x += step) pixel(vertices + 3 * x, normals + 3 * x, acc);
  }
};

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_ICP_AVX2 1

/// Horizontal sum of eight float lanes in double, lane 0 first.
__attribute__((target("avx2,fma"))) inline double lane_sum(__m256 v) {
  alignas(32) float f[8];
  _mm256_store_ps(f, v);
  double s = 0.0;
  for (float x : f) s += static_cast<double>(x);
  return s;
}

/// Eight copies of f.
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT inline __m256 bc(float f) {
  return _mm256_set1_ps(f);
}

/// Row i of the row-major 3x3 `m` times (x, y, z) on eight lanes, as m0 x + m1 y + m2 z left to
/// right without fused multiply-adds (the scalar association's operations).
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT inline __m256 rotate_row(const float* m,
                                                                                int i, __m256 x,
                                                                                __m256 y,
                                                                                __m256 z) {
  return _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(bc(m[3 * i]), x), _mm256_mul_ps(bc(m[3 * i + 1]), y)),
      _mm256_mul_ps(bc(m[3 * i + 2]), z));
}

/// Eight points base + offset[i] (x, y, z floats each) as x, y, z lanes; reads the float after
/// each point too.
__attribute__((target("avx2,fma"))) inline void load_xyz8(const float* base, const int* offset,
                                                          __m256& x, __m256& y, __m256& z) {
  __m256 r[4];
  for (int i = 0; i < 4; ++i)
    r[i] = _mm256_set_m128(_mm_loadu_ps(base + offset[i + 4]), _mm_loadu_ps(base + offset[i]));
  // 4x4 transposes within each 128-bit half: lanes 0-3 are points 0-3, lanes 4-7 points 4-7.
  const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]);  // x0 x1 y0 y1
  const __m256 t1 = _mm256_unpackhi_ps(r[0], r[1]);  // z0 z1 . .
  const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]);  // x2 x3 y2 y3
  const __m256 t3 = _mm256_unpackhi_ps(r[2], r[3]);  // z2 z3 . .
  x = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
  y = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
  z = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
}

/// Associator::row_portable() on eight pixels at a time with AVX2: the same correspondences (the
/// association repeats the scalar operations lane by lane, without fused multiply-adds); the
/// normal equations are summed per lane in float with FMAs and the lanes added in double, then
/// the scalar tail of the row. Adds the row to `acc`.
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT void row_avx2(const Associator& a,
                                                                     const float* vertices,
                                                                     const float* normals, int x0,
                                                                     int width, int step,
                                                                     Accumulator<double>& acc) {
  const int count = x0 < width ? (width - x0 + step - 1) / step : 0;
  // Each pixel is read as four floats (x, y, z and the next pixel's x): a block never ends on
  // the row's last pixel, so those reads stay inside the row.
  int blocks = count / 8;
  if (blocks > 0 && x0 + (8 * blocks - 1) * step >= width - 1) --blocks;
  int frame_offset[8];
  for (int i = 0; i < 8; ++i) frame_offset[i] = 3 * step * i;
  // Model points are read the same way, except the image's last pixel (its extra float would lie
  // past the end): a block that needs it gathers.
  const __m256i model_last = _mm256_set1_epi32(a.model_last);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 half = _mm256_set1_ps(0.5f);
  const __m256 one = _mm256_set1_ps(1.0f);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
  __m256 sa[21], sb[6], sr = zero;
  for (__m256& s : sa) s = zero;
  for (__m256& s : sb) s = zero;
  int inliers = 0, valid = 0;
  for (int b = 0; b < blocks; ++b) {
    const int x = x0 + 8 * b * step;
    const float* fv = vertices + 3 * x;
    const float* fn = normals + 3 * x;
    __m256 vx, vy, vz, nx, ny, nz;
    load_xyz8(fv, frame_offset, vx, vy, vz);
    __m256 ok = _mm256_cmp_ps(vz, zero, _CMP_GT_OQ);
    if (_mm256_movemask_ps(ok) == 0) continue;
    load_xyz8(fn, frame_offset, nx, ny, nz);
    const __m256 n_zero = _mm256_and_ps(
        _mm256_and_ps(_mm256_cmp_ps(nx, zero, _CMP_EQ_OQ), _mm256_cmp_ps(ny, zero, _CMP_EQ_OQ)),
        _mm256_cmp_ps(nz, zero, _CMP_EQ_OQ));
    ok = _mm256_andnot_ps(n_zero, ok);
    const int valid_bits = _mm256_movemask_ps(ok);
    if (valid_bits == 0) continue;
    valid += __builtin_popcount(static_cast<unsigned>(valid_bits));
    // p = R v + t, summed left to right as in the scalar code.
    const __m256 px = _mm256_add_ps(rotate_row(a.rot, 0, vx, vy, vz), bc(a.t[0]));
    const __m256 py = _mm256_add_ps(rotate_row(a.rot, 1, vx, vy, vz), bc(a.t[1]));
    const __m256 pz = _mm256_add_ps(rotate_row(a.rot, 2, vx, vy, vz), bc(a.t[2]));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(pz, zero, _CMP_GT_OQ));
    const __m256 u = _mm256_add_ps(_mm256_div_ps(_mm256_mul_ps(bc(a.fx), px), pz), bc(a.cx));
    const __m256 w = _mm256_add_ps(_mm256_div_ps(_mm256_mul_ps(bc(a.fy), py), pz), bc(a.cy));
    const __m256 lo = bc(-0.5f);
    ok = _mm256_and_ps(
        ok, _mm256_and_ps(_mm256_cmp_ps(u, lo, _CMP_GE_OQ), _mm256_cmp_ps(w, lo, _CMP_GE_OQ)));
    ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(u, bc(a.max_u), _CMP_LT_OQ),
                                         _mm256_cmp_ps(w, bc(a.max_v), _CMP_LT_OQ)));
    if (_mm256_movemask_ps(ok) == 0) continue;
    // static_cast<int>(u + 0.5f) truncates toward zero: u + 0.5 >= 0 on the kept lanes.
    const __m256i ui = _mm256_cvttps_epi32(_mm256_add_ps(u, half));
    const __m256i vi = _mm256_cvttps_epi32(_mm256_add_ps(w, half));
    __m256i index = _mm256_mullo_epi32(
        _mm256_add_epi32(_mm256_mullo_epi32(vi, _mm256_set1_epi32(a.model_width)), ui),
        _mm256_set1_epi32(3));
    index = _mm256_and_si256(index, _mm256_castps_si256(ok));  // rejected lanes read pixel 0
    __m256 qx, qy, qz, mx, my, mz;
    if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(index, model_last)) == 0) {
      alignas(32) int model_offset[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(model_offset), index);
      load_xyz8(a.model_vertices, model_offset, qx, qy, qz);
      load_xyz8(a.model_normals, model_offset, mx, my, mz);
    } else {
      qx = _mm256_i32gather_ps(a.model_vertices, index, 4);
      qy = _mm256_i32gather_ps(a.model_vertices + 1, index, 4);
      qz = _mm256_i32gather_ps(a.model_vertices + 2, index, 4);
      mx = _mm256_i32gather_ps(a.model_normals, index, 4);
      my = _mm256_i32gather_ps(a.model_normals + 1, index, 4);
      mz = _mm256_i32gather_ps(a.model_normals + 2, index, 4);
    }
    const __m256 m_zero = _mm256_and_ps(
        _mm256_and_ps(_mm256_cmp_ps(mx, zero, _CMP_EQ_OQ), _mm256_cmp_ps(my, zero, _CMP_EQ_OQ)),
        _mm256_cmp_ps(mz, zero, _CMP_EQ_OQ));
    ok = _mm256_and_ps(ok, _mm256_andnot_ps(m_zero, _mm256_cmp_ps(qz, zero, _CMP_GT_OQ)));
    const __m256 dx = _mm256_sub_ps(px, qx);
    const __m256 dy = _mm256_sub_ps(py, qy);
    const __m256 dz = _mm256_sub_ps(pz, qz);
    const __m256 dist_sq = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(dist_sq, bc(a.max_distance_sq), _CMP_LE_OQ));
    const __m256 rnx = rotate_row(a.rot, 0, nx, ny, nz);
    const __m256 rny = rotate_row(a.rot, 1, nx, ny, nz);
    const __m256 rnz = rotate_row(a.rot, 2, nx, ny, nz);
    const __m256 cos_angle = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(rnx, mx), _mm256_mul_ps(rny, my)), _mm256_mul_ps(rnz, mz));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(cos_angle, bc(a.min_normal_cos), _CMP_GE_OQ));
    const int inlier_bits = _mm256_movemask_ps(ok);
    if (inlier_bits == 0) continue;
    inliers += __builtin_popcount(static_cast<unsigned>(inlier_bits));
    const __m256 r =
        _mm256_and_ps(ok, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(mx, dx), _mm256_mul_ps(my, dy)),
                                        _mm256_mul_ps(mz, dz)));
    const __m256 j[6] = {
        _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(py, mz), _mm256_mul_ps(pz, my))),
        _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(pz, mx), _mm256_mul_ps(px, mz))),
        _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(px, my), _mm256_mul_ps(py, mx))),
        _mm256_and_ps(ok, mx),
        _mm256_and_ps(ok, my),
        _mm256_and_ps(ok, mz)};
    // Huber weight on r / s with the depth noise scale s = max(1, (z / z_ref)^2): 1 up to the
    // threshold, huber s / |r| above (rejected lanes have r = 0), then divided by s^2.
    const __m256 abs_r = _mm256_and_ps(abs_mask, r);
    const __m256 noise =
        _mm256_max_ps(one, _mm256_mul_ps(_mm256_mul_ps(pz, pz), bc(a.inv_noise_depth_sq)));
    const __m256 huber_scaled = _mm256_mul_ps(bc(a.huber), noise);
    const __m256 weight = _mm256_and_ps(
        ok, _mm256_div_ps(_mm256_blendv_ps(_mm256_div_ps(huber_scaled, abs_r), one,
                                           _mm256_cmp_ps(abs_r, huber_scaled, _CMP_LE_OQ)),
                          _mm256_mul_ps(noise, noise)));
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      const __m256 wj = _mm256_mul_ps(weight, j[i]);
      for (int c = i; c < 6; ++c, ++k) sa[k] = _mm256_fmadd_ps(wj, j[c], sa[k]);
      sb[i] = _mm256_fmadd_ps(wj, r, sb[i]);
    }
    sr = _mm256_fmadd_ps(r, r, sr);
  }
  Accumulator<double> row;
  for (int k = 0; k < 21; ++k) row.a[k] = lane_sum(sa[k]);
  for (int i = 0; i < 6; ++i) row.b[i] = lane_sum(sb[i]);
  row.residual_sq = lane_sum(sr);
  row.inliers = inliers;
  row.valid = valid;
  acc.add(row);
  Accumulator<float> tail;
  a.row_portable(vertices, normals, x0 + 8 * blocks * step, width, step, tail);
  acc.add(tail);
}
#endif

void check_sizes(const PointMaps& frame, const PointMaps& model) {
  if (frame.vertices.width() != frame.normals.width() ||
      frame.vertices.height() != frame.normals.height() ||
      model.vertices.width() != model.normals.width() ||
      model.vertices.height() != model.normals.height())
    throw usage_error("icp: vertex and normal maps differ in size");
}

/// Left-multiplied increment exp(xi), xi = (omega, tau).
Pose increment(const Eigen::Matrix<double, 6, 1>& xi) {
  const Eigen::Vector3d omega = xi.head<3>();
  const double angle = omega.norm();
  const Eigen::Matrix3d R = angle > 0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                                      : Eigen::Matrix3d::Identity();
  return Pose(R, xi.tail<3>());
}

/// The increment xi with increment(xi) = D: D's rotation vector and D's translation.
Eigen::Matrix<double, 6, 1> increment_of(const Pose& D) {
  const Eigen::AngleAxisd aa(D.rotation());
  Eigen::Matrix<double, 6, 1> xi;
  xi.head<3>() = aa.angle() * aa.axis();
  xi.tail<3>() = D.translation();
  return xi;
}

}  // namespace

Eigen::Matrix<double, 6, 1> solve_icp_system(const Eigen::Matrix<double, 6, 6>& A,
                                             const Eigen::Matrix<double, 6, 1>& b,
                                             const Eigen::Matrix<double, 6, 1>& prior,
                                             double weak_ratio, bool& degenerate) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(A);
  const Eigen::Matrix<double, 6, 1> lambda = eig.eigenvalues();
  const double largest = lambda.maxCoeff();
  degenerate = true;
  if (!(largest > 0.0)) return prior;
  const Eigen::Matrix<double, 6, 6>& V = eig.eigenvectors();
  const Eigen::Matrix<double, 6, 1> rhs = V.transpose() * (-b);
  const Eigen::Matrix<double, 6, 1> p = V.transpose() * prior;
  const double unconstrained = kDegenerateEigenRatio * largest;
  const double floor = std::max(weak_ratio * largest, unconstrained);
  Eigen::Matrix<double, 6, 1> coeff;
  degenerate = false;
  for (int i = 0; i < 6; ++i) {
    if (lambda[i] >= floor) {
      coeff[i] = rhs[i] / lambda[i];
      continue;
    }
    degenerate = true;
    // Information lambda from the data and floor - lambda from the prior: the minimiser of
    // lambda (c - rhs / lambda)^2 + (floor - lambda) (c - p)^2.
    coeff[i] = lambda[i] > unconstrained ? (rhs[i] + (floor - lambda[i]) * p[i]) / floor : p[i];
  }
  return V * coeff;
}

const char* to_string(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kGood:
      return "good";
    case TrackingStatus::kPoor:
      return "poor";
    case TrackingStatus::kLost:
      break;
  }
  return "lost";
}

namespace {

/// Rows of `frame` reduced in fixed groups of kRowsPerGroup: a deterministic TBB reduction
/// (simple partitioner, one group per leaf), so the summation tree never depends on the thread
/// count. `row(acc, vertices, normals, x0)` adds one row's pixels x0, x0 + step, ... to acc.
template <typename RowFn>
IcpSystem reduce_rows(const PointMaps& frame, int step, const RowFn& row) {
  const int height = frame.vertices.height();
  const int groups = (height + kRowsPerGroup - 1) / kRowsPerGroup;
  const Accumulator<double> total = tbb::parallel_deterministic_reduce(
      tbb::blocked_range<int>(0, groups, 1), Accumulator<double>(),
      [&](const tbb::blocked_range<int>& range, Accumulator<double> acc) {
        for (int g = range.begin(); g < range.end(); ++g) {
          const int y_end = std::min(height, (g + 1) * kRowsPerGroup);
          for (int y = g * kRowsPerGroup; y < y_end; ++y)
            row(acc, reinterpret_cast<const float*>(frame.vertices.row(y)),
                reinterpret_cast<const float*>(frame.normals.row(y)), y % step);
        }
        return acc;
      },
      [](Accumulator<double> a, const Accumulator<double>& b) {
        a.add(b);
        return a;
      });
  return total.system();
}

}  // namespace

IcpSystem icp_system_portable(const PointMaps& frame, const PointMaps& model,
                              const Pose& T_model_camera, const TrackingConfig& config,
                              int pixel_step) {
  check_sizes(frame, model);
  const int step = std::max(1, pixel_step);
  const Associator assoc(model, T_model_camera, config);
  const int width = frame.vertices.width();
  return reduce_rows(frame, step,
                     [&](Accumulator<double>& acc, const float* v, const float* n, int x0) {
                       // Float sums over one row (as many terms as the image is wide).
                       Accumulator<float> row;
                       assoc.row_portable(v, n, x0, width, step, row);
                       acc.add(row);
                     });
}

IcpSystem icp_system(const PointMaps& frame, const PointMaps& model, const Pose& T_model_camera,
                     const TrackingConfig& config, int pixel_step) {
#if defined(AOSCAN_ICP_AVX2)
  if (cpu_has_avx2_fma()) {
    check_sizes(frame, model);
    const int step = std::max(1, pixel_step);
    const Associator assoc(model, T_model_camera, config);
    const int width = frame.vertices.width();
    return reduce_rows(frame, step,
                       [&](Accumulator<double>& acc, const float* v, const float* n, int x0) {
                         row_avx2(assoc, v, n, x0, width, step, acc);
                       });
  }
#endif
  return icp_system_portable(frame, model, T_model_camera, config, pixel_step);
}

IcpSystem icp_system_reference(const PointMaps& frame, const PointMaps& model,
                               const Pose& T_model_camera, const TrackingConfig& config,
                               int pixel_step) {
  check_sizes(frame, model);
  const int step = std::max(1, pixel_step);
  const Associator assoc(model, T_model_camera, config);
  Accumulator<double> total;
  for (int y = 0; y < frame.vertices.height(); ++y)
    for (int x = 0; x < frame.vertices.width(); ++x)
      if ((x - y % step) % step == 0)
        assoc.pixel(frame.vertices(x, y).data(), frame.normals(x, y).data(), total);
  return total.system();
}

void downsample_model(const PointMaps& in, PointMaps& out) {
  out.intrinsics = in.intrinsics.scaled(1);
  const int w = in.vertices.width() / 2;
  const int h = in.vertices.height() / 2;
  out.vertices.resize(w, h, Eigen::Vector3f::Zero());
  out.normals.resize(w, h, Eigen::Vector3f::Zero());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      out.vertices(x, y) = in.vertices(2 * x, 2 * y);
      out.normals(x, y) = in.normals(2 * x, 2 * y);
    }
  }
}

IcpResult icp(const DepthPyramid& frame, const RaycastResult& model,
              const Pose& T_world_camera_init, const Pose& T_world_camera_prior,
              const TrackingConfig& config, IcpWorkspace& workspace) {
  IcpResult result;
  result.T_world_camera = T_world_camera_init;
  if (!T_world_camera_init.finite() || !model.T_world_camera.finite()) return result;

  // Each level associates into the model at the coarsest resolution that is still at least the
  // frame level's: the raycast itself while it is not finer, else halved as often as needed.
  const PointMaps* model_maps[kPyramidLevels];
  const PointMaps* current = &model.maps;
  if (config.model_normal_radius_px > 0) {
    smooth_model_normals(model.maps, config.model_normal_radius_px,
                         static_cast<float>(config.model_normal_max_distance_m), workspace.model[0],
                         workspace.smoothing_planes);
    current = &workspace.model[0];
  }
  for (int level = 0; level < kPyramidLevels; ++level) {
    const int frame_width = frame.maps[level].vertices.width();
    if (level > 0 && current->vertices.width() / 2 >= frame_width &&
        current->vertices.width() >= 2) {
      downsample_model(*current, workspace.model[level]);
      current = &workspace.model[level];
    }
    model_maps[level] = current;
  }
  const int iterations[kPyramidLevels] = {config.iterations_level0, config.iterations_level1,
                                          config.iterations_level2};

  Pose T_model_camera = model.T_world_camera.inverse() * T_world_camera_init;
  const Pose T_model_prior = T_world_camera_prior.finite()
                                 ? model.T_world_camera.inverse() * T_world_camera_prior
                                 : T_model_camera;
  IcpSystem last;
  bool evaluated_level0 = false;
  for (int level = kPyramidLevels - 1; level >= 0; --level) {
    for (int it = 0; it < iterations[level]; ++it) {
      const IcpSystem s = icp_system(frame.maps[level], *model_maps[level], T_model_camera, config,
                                     level == 0 ? config.level0_pixel_step : 1);
      if (level == 0) {
        last = s;
        evaluated_level0 = true;
      }
      if (s.inliers < 6) break;
      bool degenerate = false;
      const Eigen::Matrix<double, 6, 1> xi =
          solve_icp_system(s.A, s.b, increment_of(T_model_prior * T_model_camera.inverse()),
                           config.weak_direction_ratio, degenerate);
      if (level == 0) result.degenerate = degenerate;
      if (!xi.allFinite()) break;
      T_model_camera = increment(xi) * T_model_camera;
      ++result.iterations;
      if (xi.head<3>().norm() < kConvergedRotation && xi.tail<3>().norm() < kConvergedTranslation)
        break;
    }
  }
  if (!evaluated_level0) {
    last =
        icp_system(frame.maps[0], *model_maps[0], T_model_camera, config, config.level0_pixel_step);
    bool degenerate = false;
    solve_icp_system(last.A, last.b, Eigen::Matrix<double, 6, 1>::Zero(),
                     config.weak_direction_ratio, degenerate);
    result.degenerate = degenerate;
  }

  result.inliers = last.inliers;
  result.valid_pixels = last.valid;
  result.inlier_ratio = last.valid > 0 ? static_cast<double>(last.inliers) / last.valid : 0.0;
  result.rms_residual_m = last.inliers > 0 ? std::sqrt(last.residual_sq / last.inliers) : 0.0;

  const Pose estimate = (model.T_world_camera * T_model_camera).normalized();
  if (!estimate.finite()) return result;
  const Pose motion = T_world_camera_init.inverse() * estimate;
  result.translation_m = motion.translation().norm();
  result.rotation_deg = Eigen::AngleAxisd(motion.rotation()).angle() * 180.0 / M_PI;
  if (last.inliers < kMinInliers || result.inlier_ratio < config.lost_inlier_ratio ||
      result.translation_m > config.max_translation_m ||
      result.rotation_deg > config.max_rotation_deg)
    return result;
  result.T_world_camera = estimate;
  result.status = result.degenerate || result.inlier_ratio < config.poor_inlier_ratio ||
                          result.rms_residual_m > config.poor_rms_residual_m
                      ? TrackingStatus::kPoor
                      : TrackingStatus::kGood;
  return result;
}

IcpResult icp(const DepthPyramid& frame, const RaycastResult& model,
              const Pose& T_world_camera_init, const TrackingConfig& config,
              IcpWorkspace& workspace) {
  return icp(frame, model, T_world_camera_init, T_world_camera_init, config, workspace);
}

IcpResult icp(const DepthPyramid& frame, const RaycastResult& model,
              const Pose& T_world_camera_init, const TrackingConfig& config) {
  IcpWorkspace workspace;
  return icp(frame, model, T_world_camera_init, T_world_camera_init, config, workspace);
}

}  // namespace aoscan
