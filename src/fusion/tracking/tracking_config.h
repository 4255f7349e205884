/// @file tracking_config.h
/// @brief Configuration of camera tracking (section `tracking`).
///
/// The struct lists its fields once in `visit()`: loading (`--config`, `--set`), validation,
/// `aoscan config` and the README's table are all driven by that list (pipeline/config.h).
#pragma once

namespace aoscan {

/// Frame-to-model projective point-to-plane ICP and the per-frame tracking status.
struct TrackingConfig {
  int iterations_level0 = 2;   ///< Gauss-Newton iterations at full resolution
  int iterations_level1 = 5;   ///< ... at half resolution
  int iterations_level2 = 10;  ///< ... at quarter resolution (done first)
  /// Full resolution associates every n-th pixel of each row, staggered row to row (2 = a
  /// checkerboard, half the pixels); coarser levels use every pixel.
  int level0_pixel_step = 2;
  double max_distance_m = 0.1;         ///< correspondences farther apart are rejected (m)
  double max_normal_angle_deg = 30.0;  ///< correspondences whose normals differ more are rejected
  double huber_delta_m = 0.005;        ///< Huber robust weight: residuals above are down-weighted
  /// Depth-dependent noise of the ICP residuals: beyond this depth a correspondence's residual
  /// is scaled by s = (z / noise_reference_depth_m)^2 (the axial noise of a triangulating sensor
  /// grows with z^2): Huber threshold huber_delta_m * s and weight 1 / s^2. 0 weighs all depths
  /// alike.
  double noise_reference_depth_m = 1.0;
  double lost_inlier_ratio = 0.1;     ///< inliers / valid frame pixels below this: lost
  double poor_inlier_ratio = 0.3;     ///< inliers / valid frame pixels below this: poor
  double poor_rms_residual_m = 0.01;  ///< point-to-plane RMS residual above this: poor
  double max_translation_m = 0.15;    ///< motion from the initial pose above this: lost (m)
  double max_rotation_deg = 20.0;     ///< rotation from the initial pose above this: lost (deg)
  /// ICP uses the model raycast's normals averaged over (2 r + 1)^2 pixels of the raycast (points
  /// within model_normal_max_distance_m of the pixel's): TSDF-gradient normals of a model fused
  /// from few noisy frames scatter by tens of degrees at 2-3 m, which both rejects most
  /// correspondences at the normal-angle test and biases the point-to-plane solution along the
  /// weakly constrained directions of a room (walls and floor). 0 uses the raw normals.
  int model_normal_radius_px = 2;
  double model_normal_max_distance_m = 0.05;  ///< neighbours farther away (m) are not averaged
  /// Degeneracy-aware update (Zhang, Kaess & Singh 2016): a direction of the ICP system whose
  /// eigenvalue is below this fraction of the largest is hardly measured (a wall and the floor
  /// alone leave the translation along their edge to depth noise, at about 0.02 % in the room
  /// scenes, against 1 % for the weakest direction of a well-constrained view). Such a direction
  /// gets the information missing up to the floor from the motion prior (velocity_smoothing):
  /// far below it the estimate follows the prior, near it mostly the data. 0 keeps only the
  /// numerically unconstrained directions (below 1e-6) at the prior.
  double weak_direction_ratio = 0.0005;
  /// The motion prior of the weak directions is the previous pose moved on by the camera's
  /// frame-to-frame motion, smoothed exponentially with this weight of the newest motion (1: the
  /// last motion alone). 0: no velocity, the prior is the previous pose.
  double velocity_smoothing = 0.3;

  template <class V>
  void visit(V& v) {
    v.integer("iterations_level0", iterations_level0, "ICP iterations at full resolution", 0, 100);
    v.integer("iterations_level1", iterations_level1, "ICP iterations at half resolution", 0, 100);
    v.integer("iterations_level2", iterations_level2, "ICP iterations at quarter resolution", 0,
              100);
    v.integer("level0_pixel_step", level0_pixel_step,
              "ICP at full resolution uses every n-th pixel, staggered by row (checkerboard at 2)",
              1, 8);
    v.number("max_distance_m", max_distance_m, "ICP correspondence distance rejection (m)", 1e-4,
             10.0);
    v.integer("model_normal_radius_px", model_normal_radius_px,
              "ICP averages the model raycast's normals over this radius (pixels of the raycast); "
              "0 uses them as they are",
              0, 8);
    v.number(
        "model_normal_max_distance_m", model_normal_max_distance_m,
        "model normal averaging: only neighbours within this distance of the pixel's point (m)",
        1e-3, 1.0);
    v.number("noise_reference_depth_m", noise_reference_depth_m,
             "ICP: beyond this depth (m) residuals count as noisier by (z / this)^2 (Huber "
             "threshold times that, weight over its square); 0 weighs all depths alike",
             0.0, 100.0);
    v.number("weak_direction_ratio", weak_direction_ratio,
             "ICP directions with an eigenvalue below this fraction of the largest take the "
             "missing information from the motion prior; 0: only unconstrained ones",
             0.0, 1.0);
    v.number("velocity_smoothing", velocity_smoothing,
             "motion prior of the weak ICP directions: weight of the newest frame-to-frame "
             "motion in the smoothed camera velocity; 0: the previous pose",
             0.0, 1.0);
    v.number("max_normal_angle_deg", max_normal_angle_deg,
             "ICP correspondence normal-angle rejection (degrees)", 0.0, 180.0);
    v.number("huber_delta_m", huber_delta_m, "ICP Huber threshold of the residual (m)", 1e-5, 1.0);
    v.number("lost_inlier_ratio", lost_inlier_ratio,
             "tracking lost below this fraction of valid pixels matched", 0.0, 1.0);
    v.number("poor_inlier_ratio", poor_inlier_ratio,
             "tracking poor below this fraction of valid pixels matched", 0.0, 1.0);
    v.number("poor_rms_residual_m", poor_rms_residual_m,
             "tracking poor above this point-to-plane RMS residual (m)", 0.0, 1.0);
    v.number("max_translation_m", max_translation_m,
             "tracking lost when a frame moves farther than this from its initial pose (m)", 0.0,
             100.0);
    v.number("max_rotation_deg", max_rotation_deg,
             "tracking lost when a frame turns more than this from its initial pose (deg)", 0.0,
             180.0);
  }
};

}  // namespace aoscan
