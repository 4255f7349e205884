/// @file registration.h
/// @brief Estimating the colour camera of a depth recording (depth-to-colour transform and colour
/// intrinsics) by aligning depth discontinuities with colour edges over many frames.
///
/// Each frame gives depth-edge points (the nearer side of a depth jump, unprojected with the depth
/// intrinsics) and the distance transform of the colour image's Canny edges. A candidate colour
/// camera projects the points into the colour image; its score is the truncated distance there. A
/// coarse grid search (image shift, baseline, focal length) is followed by Levenberg-Marquardt on
/// the distance transform's gradient with a shrinking truncation radius.
///
/// What is fitted: the rotation (3), the translation (3) and the focal length fx = fy. The
/// principal point stays at its nominal value (the image centre): to first order a principal-point
/// shift and a small rotation about the image axes move every pixel alike, so the two cannot be
/// told apart by edges; the rotation absorbs the difference (FitOptions::fit_principal_point
/// frees cx, cy for data that separates them).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/colour.h"
#include "core/image.h"
#include "core/intrinsics.h"

namespace aoscan::colour_registration {

/// Where a depth jump's edge point is put.
enum class EdgePlacement {
  /// At the centre of the nearer pixel: for real depth cameras, whose nearer surface reaches a
  /// little past the true edge (a Kinect v1's block matching widens foregrounds), so that pixel is
  /// closer to the edge than the boundary is (RedKitchen: held-out median 1.47 px against 1.55).
  kNearPixel,
  /// On the boundary between the two pixel centres: for exact depth (synthetic frames), where it is
  /// the edge's unbiased estimate.
  kBoundary,
};

/// How edges are found in one depth/colour pair.
struct EdgeOptions {
  EdgePlacement placement = EdgePlacement::kNearPixel;
  double min_jump_m = 0.05;    ///< a depth jump is at least this (metres) ...
  double min_jump_rel = 0.05;  ///< ... and at least this fraction of the nearer depth
  int max_points = 2000;       ///< depth-edge points kept per frame (evenly thinned)
  int border_px = 4;           ///< depth edges this close to the image border are ignored
  double canny_low = 30.0;     ///< Canny thresholds on the blurred grey image (L2 gradient)
  double canny_high = 90.0;
  double blur_sigma_px = 1.2;  ///< Gaussian blur before Canny
};

/// One frame ready for registration.
struct EdgeFrame {
  int frame = -1;                             ///< index in the recording
  std::vector<Eigen::Vector3d> points;        ///< depth-edge points, depth camera frame (m)
  std::vector<Eigen::Vector2d> depth_pixels;  ///< the same points in depth-image pixels
  Image<float> distance;                      ///< px to the nearest colour edge (colour image)
  int colour_edge_pixels = 0;
};

/// Depth-edge points of a depth image (raw units, `depth_scale` per metre; 0 and 65535 invalid).
/// A jump between 4-neighbours counts when both sides are valid, it exceeds the thresholds, and the
/// pixel beyond each side continues that side (flying pixels between the two do not count). The
/// point is unprojected at the nearer depth, placed as `options.placement` says.
void find_depth_edges(const Image<std::uint16_t>& depth, double depth_scale,
                      const Intrinsics& depth_intrinsics, const EdgeOptions& options,
                      std::vector<Eigen::Vector3d>& points,
                      std::vector<Eigen::Vector2d>& depth_pixels);

/// The distance transform of the Canny edges of a grey image into `frame`.
void colour_edges_from_grey(const Image<std::uint8_t>& grey, const EdgeOptions& options,
                            EdgeFrame& frame);

/// The EdgeFrame of a depth image and an RGB colour image.
EdgeFrame make_edge_frame(const Image<std::uint16_t>& depth, double depth_scale,
                          const Intrinsics& depth_intrinsics, const Image<Rgb8>& colour,
                          const EdgeOptions& options, int frame_index = 0);

/// Distances from projected depth-edge points to the nearest colour edge.
struct EdgeDistances {
  std::size_t points = 0;   ///< points that land inside the colour image (measured)
  std::size_t outside = 0;  ///< points that land outside it (not measured)
  double median_px = 0.0;
  double p90_px = 0.0;
  double within_2px = 0.0;  ///< fraction of measured points within 2 px
};

/// The distances with `camera` (nullptr: colour assumed registered, depth pixel (x, y) is colour
/// pixel (x, y)), bilinear in the distance transform, untruncated.
EdgeDistances measure_edge_distances(const std::vector<EdgeFrame>& frames,
                                     const ColourCamera* camera);
/// The same for one frame.
EdgeDistances measure_edge_distances(const EdgeFrame& frame, const ColourCamera* camera);

/// What a point placed at random would score: the median distance from every 4th pixel of every
/// 4th row to the nearest colour edge (how dense the colour edges are).
double chance_median_px(const std::vector<EdgeFrame>& frames);

/// How the fit runs.
struct FitOptions {
  bool fit_principal_point = false;  ///< free cx, cy too (see the file comment)
  double coarse_shift_px = 48.0;     ///< image shifts searched: +-this
  double coarse_shift_step_px = 4.0;
  std::vector<double> coarse_baseline_m = {-0.05, -0.025, 0.0, 0.025, 0.05};
  std::vector<double> coarse_focal_scale = {0.9, 0.95, 1.0, 1.05, 1.1};
  int coarse_points_per_frame = 300;
  int coarse_points_total = 6000;                        ///< fewer per frame when many frames
  std::vector<double> truncation_px = {10.0, 5.0, 3.0};  ///< LM stages
  int iterations_per_stage = 20;
  int refine_candidates = 3;  ///< best distinct coarse cells refined
};

/// The fit and what it says about itself.
struct FitResult {
  ColourCamera camera;
  double coarse_cost = 0.0;  ///< mean truncated distance of the best coarse cell (px)
  double final_cost = 0.0;   ///< mean distance truncated at the last radius (px)
  std::size_t inliers = 0;   ///< points within the last radius
  std::size_t points = 0;    ///< points used
  /// Formal standard deviations (rx, ry, rz rad; tx, ty, tz m; f, cx, cy px; 0 when kept fixed)
  /// from the last stage's normal equations: a lower bound (edge residuals are correlated).
  std::array<double, 9> sigma{};
  double condition = 0.0;  ///< condition number of the correlation-scaled normal matrix
};

using Progress = std::function<void(const std::string&)>;

/// Fits the colour camera to `frames`, starting from `nominal` (its size and principal point are
/// kept). Throws Error(kBadInput) with fewer than 200 points, Error(kFailure) when the normal
/// equations are degenerate or the result is implausible (focal length beyond 0.75-1.33x nominal,
/// translation beyond 0.2 m, rotation beyond 15 degrees).
FitResult fit_colour_camera(const std::vector<EdgeFrame>& frames, const ColourCamera& nominal,
                            const FitOptions& options = {}, const Progress& progress = {});

/// Options of a whole recording.
struct RecordingOptions {
  int max_frames = 100;  ///< frames read at most (every `step`-th of the recording)
  int step = 5;
  EdgeOptions edges;
  FitOptions fit;
  bool verbose = false;
};

/// The outcome on a recording.
struct RecordingResult {
  Intrinsics depth_intrinsics;
  double depth_scale = 0.0;
  std::string depth_calibration_origin;
  FitResult fit;
  std::vector<int> fit_frames, eval_frames;  ///< recording indices
  bool held_out = false;                     ///< eval_frames are not fit_frames
  EdgeDistances before, after;
  std::vector<EdgeDistances> before_per_frame, after_per_frame;  ///< of eval_frames
  double chance_median_px = 0.0;  ///< chance_median_px() of the measured frames
  /// How far the fitted camera moves the measured depth-edge points from where the registered
  /// assumption puts them (same pixel coordinates): median and 90th percentile, pixels.
  double offset_median_px = 0.0, offset_p90_px = 0.0;
  double read_s = 0.0, fit_s = 0.0;  ///< wall-clock seconds reading and fitting
  std::size_t skipped = 0;           ///< unreadable or unusable pairs
  std::string first_skip;            ///< the first skip's message
};

/// Reads every `step`-th depth/colour pair of a TUM-layout folder (depth.txt, rgb.txt,
/// camera.json), fits on every other usable pair and measures on the rest. Throws input_error
/// (one line naming the file) for a folder without depth.txt/rgb.txt, no usable pair, or too few
/// edges; usage_error for max_frames < 1 or step < 1.
RecordingResult register_recording(const std::string& folder, const RecordingOptions& options,
                                   const Progress& progress = {});

}  // namespace aoscan::colour_registration
