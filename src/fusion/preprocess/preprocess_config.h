/// @file preprocess_config.h
/// @brief Configuration of depth preprocessing (section `preprocess`).
///
/// The struct lists its fields once in `visit()`: loading (`--config`, `--set`), validation,
/// `aoscan config` and the README's table are all driven by that list (pipeline/config.h).
#pragma once

namespace aoscan {

/// Depth preprocessing: raw units to metres, range clip, border-outlier removal (Sabbadin et al.
/// 2016 Sec. 6).
struct PreprocessConfig {
  double min_depth_m = 0.4;           ///< nearer depths are invalid
  double max_depth_m = 4.5;           ///< farther depths are invalid
  double outlier_threshold_m = 0.02;  ///< drop a pixel when any 8-neighbour differs by more
  /// ... than outlier_threshold_m + outlier_threshold_per_m2 * depth^2 (the depth resolution of
  /// a triangulating sensor falls with depth^2; 0 gives the paper's fixed threshold). This is the
  /// fused (and SSAO raw) depth's threshold.
  double outlier_threshold_per_m2 = 0.002;
  /// The same growth for the depth that tracking reads (outlier_threshold_m +
  /// tracking_outlier_threshold_per_m2 * depth^2). A Kinect v1's disparity step is about
  /// 0.0029-0.0032 m * depth^2 (f = 525-585 px) and its axial noise 0.0019 m * depth^2, so a
  /// fixed threshold removes most of every surface beyond about 2.5 m from the tracking depth.
  double tracking_outlier_threshold_per_m2 = 0.004;
  /// Bilateral filter before tracking. Sigmas are PCL KinFu's (4.5 px, 0.03 m); KinFu's radius is
  /// 6 px (13x13 window), here 2 px (5x5) by default: a seventh of KinFu's taps per pixel, and
  /// RedKitchen tracks as well as with 7x7. 0 disables the filter.
  int bilateral_radius_px = 2;
  double bilateral_sigma_space_px = 4.5;  ///< spatial Gaussian sigma (pixels)
  double bilateral_sigma_depth_m = 0.03;  ///< depth Gaussian sigma (m); |dz| > 3 sigma is ignored
  /// Pyramid downsampling averages a 2x2 block's depths within this of the block's first valid
  /// depth (KinectFusion uses 3 sigma_depth).
  double pyramid_max_depth_diff_m = 0.09;
  /// Normal map: no normal where a right/down neighbour's depth differs by more than this (m) at
  /// level 0; doubled at each pyramid level because neighbours are twice as far apart.
  double normal_max_depth_jump_m = 0.05;

  template <class V>
  void visit(V& v) {
    v.number("min_depth_m", min_depth_m, "nearest depth kept (m)", 0.0, 100.0);
    v.number("max_depth_m", max_depth_m, "farthest depth kept (m)", 0.0, 100.0);
    v.number("outlier_threshold_m", outlier_threshold_m,
             "border-outlier removal: a pixel goes when an 8-neighbour differs in depth by more "
             "than this (m) plus outlier_threshold_per_m2 * depth^2; 0 disables",
             0.0, 10.0);
    v.number(
        "outlier_threshold_per_m2", outlier_threshold_per_m2,
        "border-outlier removal of the fused depth: growth of the threshold with the square of "
        "the pixel's depth (1/m); 0 keeps it fixed as in the paper",
        0.0, 1.0);
    v.number("tracking_outlier_threshold_per_m2", tracking_outlier_threshold_per_m2,
             "border-outlier removal of the tracking depth: the same growth with depth^2 (1/m); 0 "
             "keeps it fixed as in the paper",
             0.0, 1.0);
    v.integer("bilateral_radius_px", bilateral_radius_px,
              "bilateral filter half-window (px); 0 disables the filter", 0, 16);
    v.number("bilateral_sigma_space_px", bilateral_sigma_space_px,
             "bilateral filter spatial sigma (px)", 0.1, 100.0);
    v.number("bilateral_sigma_depth_m", bilateral_sigma_depth_m,
             "bilateral filter depth sigma (m); neighbours beyond 3 sigma are ignored", 1e-4, 1.0);
    v.number("pyramid_max_depth_diff_m", pyramid_max_depth_diff_m,
             "pyramid 2x2 downsampling averages depths within this of the block's first valid "
             "depth (m)",
             1e-4, 10.0);
    v.number("normal_max_depth_jump_m", normal_max_depth_jump_m,
             "normal map: no normal across a depth jump larger than this at level 0 (m)", 1e-4,
             10.0);
  }
};

}  // namespace aoscan
