/// @file icp.cpp
/// @brief Projective point-to-plane ICP: per-pixel association and Huber-weighted normal
/// equations reduced deterministically, pseudo-inverse Gauss-Newton steps, tracking status.
#include "fusion/icp.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/parallel_for.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "core/status.h"

namespace aoscan {
namespace {

/// Image rows reduced by one task; fixed so the summation order never depends on threads.
constexpr int kRowsPerGroup = 4;
/// Fewer inliers than this at full resolution: lost, whatever the ratio.
constexpr int kMinInliers = 64;
/// Eigenvalues of the system below this fraction of the largest are treated as unconstrained.
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

/// Everything the per-pixel association needs, in float.
struct Associator {
  Eigen::Matrix3f R;
  Eigen::Vector3f t;
  float fx, fy, cx, cy;
  float max_u, max_v;
  float max_distance_sq;
  float min_normal_cos;
  float huber;
  const PointMaps* model;

  Associator(const PointMaps& model_maps, const Pose& T_model_camera, const TrackingConfig& config)
      : R(T_model_camera.rotation().cast<float>()),
        t(T_model_camera.translation().cast<float>()),
        fx(static_cast<float>(model_maps.intrinsics.fx)),
        fy(static_cast<float>(model_maps.intrinsics.fy)),
        cx(static_cast<float>(model_maps.intrinsics.cx)),
        cy(static_cast<float>(model_maps.intrinsics.cy)),
        max_u(static_cast<float>(model_maps.vertices.width()) - 0.5f),
        max_v(static_cast<float>(model_maps.vertices.height()) - 0.5f),
        max_distance_sq(static_cast<float>(config.max_distance_m * config.max_distance_m)),
        min_normal_cos(static_cast<float>(std::cos(config.max_normal_angle_deg * M_PI / 180.0))),
        huber(static_cast<float>(config.huber_delta_m)),
        model(&model_maps) {}

  /// Adds the correspondence of frame pixel (x, y), if any, in T arithmetic.
  template <typename T>
  void pixel(const PointMaps& frame, int x, int y, Accumulator<T>& acc) const {
    const Eigen::Vector3f& v = frame.vertices(x, y);
    const Eigen::Vector3f& n = frame.normals(x, y);
    if (!(v.z() > 0.0f) || n.isZero()) return;
    ++acc.valid;
    const Eigen::Vector3f p = R * v + t;
    if (!(p.z() > 0.0f)) return;
    const float u = fx * p.x() / p.z() + cx;
    const float w = fy * p.y() / p.z() + cy;
    if (!(u >= -0.5f && w >= -0.5f && u < max_u && w < max_v)) return;
    const int ui = static_cast<int>(u + 0.5f);
    const int vi = static_cast<int>(w + 0.5f);
    const Eigen::Vector3f& q = model->vertices(ui, vi);
    const Eigen::Vector3f& nm = model->normals(ui, vi);
    if (!(q.z() > 0.0f) || nm.isZero()) return;
    const Eigen::Vector3f diff = p - q;
    if (!(diff.squaredNorm() <= max_distance_sq)) return;
    if (!((R * n).dot(nm) >= min_normal_cos)) return;
    const float r = nm.dot(diff);
    const Eigen::Vector3f pxn = p.cross(nm);
    const T j[6] = {pxn.x(), pxn.y(), pxn.z(), nm.x(), nm.y(), nm.z()};
    const float abs_r = std::abs(r);
    const T weight = abs_r <= huber ? T(1) : static_cast<T>(huber) / static_cast<T>(abs_r);
    acc.add(j, static_cast<T>(r), weight);
  }
};

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

/// Solves A xi = -b through the eigen-decomposition, leaving unconstrained directions at zero.
Eigen::Matrix<double, 6, 1> solve(const IcpSystem& s, bool& degenerate) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(s.A);
  const Eigen::Matrix<double, 6, 1> lambda = eig.eigenvalues();
  const double largest = lambda.maxCoeff();
  Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
  degenerate = false;
  if (!(largest > 0.0)) {
    degenerate = true;
    return xi;
  }
  const Eigen::Matrix<double, 6, 1> rhs = eig.eigenvectors().transpose() * (-s.b);
  Eigen::Matrix<double, 6, 1> coeff;
  for (int i = 0; i < 6; ++i) {
    if (lambda[i] > kDegenerateEigenRatio * largest) {
      coeff[i] = rhs[i] / lambda[i];
    } else {
      coeff[i] = 0.0;
      degenerate = true;
    }
  }
  xi = eig.eigenvectors() * coeff;
  return xi;
}

}  // namespace

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

IcpSystem icp_system(const PointMaps& frame, const PointMaps& model, const Pose& T_model_camera,
                     const TrackingConfig& config, int pixel_step) {
  check_sizes(frame, model);
  const int step = std::max(1, pixel_step);
  const Associator assoc(model, T_model_camera, config);
  const int height = frame.vertices.height();
  const int width = frame.vertices.width();
  const int groups = (height + kRowsPerGroup - 1) / kRowsPerGroup;
  std::vector<Accumulator<double>> partial(groups);
  tbb::parallel_for(0, groups, [&](int g) {
    Accumulator<double> acc;
    const int y_end = std::min(height, (g + 1) * kRowsPerGroup);
    for (int y = g * kRowsPerGroup; y < y_end; ++y) {
      // Float sums over one row (as many terms as the image is wide), merged in double.
      Accumulator<float> row;
      for (int x = y % step; x < width; x += step) assoc.pixel(frame, x, y, row);
      acc.add(row);
    }
    partial[g] = acc;
  });
  Accumulator<double> total;
  for (const Accumulator<double>& acc : partial) total.add(acc);
  return total.system();
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
      if ((x - y % step) % step == 0) assoc.pixel(frame, x, y, total);
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
              const Pose& T_world_camera_init, const TrackingConfig& config,
              IcpWorkspace& workspace) {
  IcpResult result;
  result.T_world_camera = T_world_camera_init;
  if (!T_world_camera_init.finite() || !model.T_world_camera.finite()) return result;

  // Each level associates into the model at the coarsest resolution that is still at least the
  // frame level's: the raycast itself while it is not finer, else halved as often as needed.
  const PointMaps* model_maps[kPyramidLevels];
  const PointMaps* current = &model.maps;
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
      const Eigen::Matrix<double, 6, 1> xi = solve(s, degenerate);
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
    solve(last, degenerate);
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
              const Pose& T_world_camera_init, const TrackingConfig& config) {
  IcpWorkspace workspace;
  return icp(frame, model, T_world_camera_init, config, workspace);
}

}  // namespace aoscan
