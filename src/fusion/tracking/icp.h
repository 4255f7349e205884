/// @file icp.h
/// @brief Frame-to-model tracking: coarse-to-fine projective point-to-plane ICP against the model
/// raycast, with distance / normal-angle rejection, Huber weights and a per-frame status.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "core/pose.h"
#include "fusion/tracking/tracking_config.h"
#include "geometry/normal_smoothing.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// Outcome of tracking one frame.
enum class TrackingStatus {
  kGood,  ///< enough inliers, small residual, plausible motion
  kPoor,  ///< tracked, but few inliers, a large residual or a degenerate (under-constrained) scene
  kLost,  ///< not tracked: the pose is the initial guess and the frame should not be fused
};

/// "good", "poor" or "lost".
const char* to_string(TrackingStatus status);

/// What icp() found.
struct IcpResult {
  Pose T_world_camera;  ///< estimated pose; the initial pose when lost
  TrackingStatus status = TrackingStatus::kLost;
  int inliers = 0;  ///< correspondences kept at full resolution (last iteration, sampled pixels)
  int valid_pixels = 0;         ///< sampled full-resolution frame pixels with a vertex and a normal
  double inlier_ratio = 0.0;    ///< inliers / valid_pixels
  double rms_residual_m = 0.0;  ///< point-to-plane RMS of the inliers (m)
  int iterations = 0;           ///< Gauss-Newton steps over all levels
  bool degenerate = false;      ///< the last system had a direction below the weak-direction floor
  double translation_m = 0.0;   ///< |motion| from the initial pose (m)
  double rotation_deg = 0.0;    ///< rotation angle from the initial pose (degrees)
};

/// Gauss-Newton normal equations of one ICP iteration for the increment xi = (omega, tau) applied
/// on the left in the model camera frame: T_model_camera <- exp(xi) * T_model_camera.
struct IcpSystem {
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();  ///< sum w J J^T
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();  ///< sum w J r
  double residual_sq = 0.0;  ///< sum of r^2 over the inliers (unweighted, m^2)
  int inliers = 0;
  int valid = 0;  ///< frame pixels with a vertex and a normal
};

/// Builds the ICP system at one pyramid level: each valid frame vertex (camera frame of the frame)
/// is moved by T_model_camera into the camera frame of the model raycast, projected into `model`
/// (camera frame of the model; nearest pixel) and paired with that model vertex / normal unless
/// they are farther apart than max_distance_m or their normals differ by more than
/// max_normal_angle_deg. Residual r = n_model . (p - q), Huber-weighted. `pixel_step` n > 1 uses
/// only the frame pixels with x = y mod n, mod n (n = 2: a checkerboard); valid and inliers count
/// those. This is the fast version: AVX2 + FMA over eight pixels when the CPU has them (else
/// icp_system_portable()), each image row summed in float and the rows in double, TBB over fixed
/// groups of rows reduced in a fixed tree: the result does not depend on the thread count. It
/// picks exactly the correspondences of the test oracle icp_system_reference() (tests/support;
/// same valid and inlier counts) and agrees with its sums up to the float rounding of the row
/// sums (about 1e-6 relative).
IcpSystem icp_system(const PointMaps& frame, const PointMaps& model, const Pose& T_model_camera,
                     const TrackingConfig& config, int pixel_step = 1);
/// The scalar path of icp_system(): the fallback that runs when the CPU lacks AVX2 + FMA (same
/// contract and tolerance; rows summed in float one pixel after another). Exposed so tests cover
/// it anywhere.
IcpSystem icp_system_portable(const PointMaps& frame, const PointMaps& model,
                              const Pose& T_model_camera, const TrackingConfig& config,
                              int pixel_step = 1);

/// One Gauss-Newton step: the increment xi solving A xi = -b in the eigenbasis of A, where the
/// data constrain it, and the increment `prior` (the one that would reach the motion prior) where
/// they hardly do. A direction whose eigenvalue lambda is below floor = weak_ratio * largest
/// (at least 1e-6 * largest) gets the information floor - lambda from the prior: its component
/// is (rhs + (floor - lambda) p) / floor, with rhs and p the components of -b and prior; below
/// 1e-6 * largest it is the prior's alone. Point-to-plane data along a weak direction are mostly
/// depth noise (and, frame to model, the model's own earlier errors), so solving for it exactly
/// lets the pose wander by centimetres there. `degenerate` is set when any direction is below
/// the floor (or A is not positive).
Eigen::Matrix<double, 6, 1> solve_icp_system(const Eigen::Matrix<double, 6, 6>& A,
                                             const Eigen::Matrix<double, 6, 1>& b,
                                             const Eigen::Matrix<double, 6, 1>& prior,
                                             double weak_ratio, bool& degenerate);

/// Reusable buffers of icp(): the model maps at every pyramid level (level 0: the raycast with
/// smoothed normals, when config.model_normal_radius_px > 0).
struct IcpWorkspace {
  std::array<PointMaps, kPyramidLevels> model;
  std::vector<float> smoothing_planes;  ///< scratch of smooth_model_normals()
};

/// Model maps at half resolution: pixel (x, y) takes the vertex and normal of pixel (2x, 2y);
/// intrinsics are `in.intrinsics.scaled(1)`. `out`'s buffers are reused.
void downsample_model(const PointMaps& in, PointMaps& out);

/// Tracks `frame` (its pyramid; camera frame of the frame) against `model` (a raycast of the
/// fused model at model.T_world_camera), starting from T_world_camera_init (usually the previous
/// pose), coarse to fine with the configured iterations per level (full resolution with
/// pixel_step = config.level0_pixel_step). The model may have any
/// resolution (its maps carry their intrinsics): each frame level associates projectively into
/// the model halved down to the coarsest resolution not below the level's (a half-resolution
/// raycast serves levels 0 and 1 as it is). The result's status is lost
/// when too few pixels match, the estimate is not finite, or it moved more than
/// max_translation_m / max_rotation_deg from the initial pose; poor when the inlier ratio or the
/// residual is bad or the system is degenerate. Never returns a non-finite pose. The directions
/// the data hardly constrain (TrackingConfig::weak_direction_ratio, solve_icp_system()) are drawn
/// to T_world_camera_prior, e.g. the previous pose moved on by the camera's velocity; the
/// well-constrained ones are not.
IcpResult icp(const DepthPyramid& frame, const RaycastResult& model,
              const Pose& T_world_camera_init, const Pose& T_world_camera_prior,
              const TrackingConfig& config, IcpWorkspace& workspace);
/// icp() with the initial pose as the prior.
IcpResult icp(const DepthPyramid& frame, const RaycastResult& model,
              const Pose& T_world_camera_init, const TrackingConfig& config,
              IcpWorkspace& workspace);
/// icp() with a temporary workspace.
IcpResult icp(const DepthPyramid& frame, const RaycastResult& model,
              const Pose& T_world_camera_init, const TrackingConfig& config);

}  // namespace aoscan
