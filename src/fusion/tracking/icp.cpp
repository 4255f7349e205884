/// @file icp.cpp
/// @brief Projective point-to-plane ICP: per-pixel association (icp_kernels.h; AVX2 rows in
/// icp_avx2.cpp) and Huber-weighted normal equations reduced deterministically, the run-time
/// choice of the row kernel, degeneracy-aware Gauss-Newton steps, tracking status.
#include "fusion/tracking/icp.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "core/status.h"
#include "fusion/tracking/icp_kernels.h"
#include "geometry/normal_smoothing.h"
#include "geometry/simd.h"

namespace aoscan {
namespace {

using icp_detail::Accumulator;
using icp_detail::Associator;

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

namespace {

/// The ICP system summed row by row: `row(assoc, acc, v, n, x0, width, step)` adds one row's
/// correspondences (the frame pixels x0, x0 + step, ...) to `acc`.
template <class RowFn>
IcpSystem icp_system_by_rows(const PointMaps& frame, const PointMaps& model,
                             const Pose& T_model_camera, const TrackingConfig& config,
                             int pixel_step, RowFn row) {
  check_sizes(frame, model);
  const int step = std::max(1, pixel_step);
  const Associator assoc(model, T_model_camera, config);
  const int width = frame.vertices.width();
  return reduce_rows(frame, step,
                     [&](Accumulator<double>& acc, const float* v, const float* n, int x0) {
                       row(assoc, acc, v, n, x0, width, step);
                     });
}

}  // namespace

IcpSystem icp_system_portable(const PointMaps& frame, const PointMaps& model,
                              const Pose& T_model_camera, const TrackingConfig& config,
                              int pixel_step) {
  return icp_system_by_rows(frame, model, T_model_camera, config, pixel_step,
                            [](const Associator& assoc, Accumulator<double>& acc, const float* v,
                               const float* n, int x0, int width, int step) {
                              // Float sums over one row (as many terms as the image is wide).
                              Accumulator<float> row;
                              assoc.row_portable(v, n, x0, width, step, row);
                              acc.add(row);
                            });
}

IcpSystem icp_system(const PointMaps& frame, const PointMaps& model, const Pose& T_model_camera,
                     const TrackingConfig& config, int pixel_step) {
#if defined(AOSCAN_ICP_AVX2)
  if (cpu_has_avx2_fma())
    return icp_system_by_rows(frame, model, T_model_camera, config, pixel_step,
                              [](const Associator& assoc, Accumulator<double>& acc,
                                 const float* v, const float* n, int x0, int width, int step) {
                                icp_detail::row_avx2(assoc, v, n, x0, width, step, acc);
                              });
#endif
  return icp_system_portable(frame, model, T_model_camera, config, pixel_step);
}

void downsample_model(const PointMaps& in, PointMaps& out) {
  out.intrinsics = in.intrinsics.scaled(1);
  const int w = in.vertices.width() / 2;
  const int h = in.vertices.height() / 2;
  out.vertices.resize_for_overwrite(w, h, Eigen::Vector3f::Zero());  // every pixel is written
  out.normals.resize_for_overwrite(w, h, Eigen::Vector3f::Zero());
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
