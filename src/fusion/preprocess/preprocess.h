/// @file preprocess.h
/// @brief Depth preprocessing: raw units to metres, border-outlier removal (Sabbadin et al. 2016
/// Sec. 6), bilateral filter, the 3-level tracking pyramid with vertex and normal maps
/// (KinectFusion).
///
/// Conventions of the whole fusion module: depth images hold metres along the optical axis as
/// float, and 0.0f marks an invalid pixel. Every function here writes into a caller-owned output
/// image that is resized (without reallocating when it is already large enough), so per-frame code
/// can reuse its buffers. Outputs must not alias inputs. All functions are deterministic and give
/// the same result for any number of TBB threads.
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "core/depth_frame.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "fusion/preprocess/preprocess_config.h"
#include "geometry/point_maps.h"

namespace aoscan {

// ---------------------------------------------------------------------------------------------
// Raw depth to metres and border-outlier removal
// ---------------------------------------------------------------------------------------------

/// Converts `frame.depth` (raw units, `frame.depth_scale` units per metre) to metres:
/// depth_m = raw / depth_scale computed in float, and 0 where raw == 0, raw == 65535 or the
/// metres lie outside [min_depth_m, max_depth_m] (inclusive; the bounds are rounded to float).
/// `depth_m` takes the frame's size. Throws input_error naming `frame.origin` when depth_scale is
/// not a finite positive number.
void depth_to_metres(const DepthFrame& frame, const PreprocessConfig& config,
                     Image<float>& depth_m);

/// Border-outlier removal of Sabbadin et al. 2016 Sec. 6: a valid pixel of depth c is removed (set
/// to 0) when any of its 8 neighbours differs from it in depth by more than t = threshold_m +
/// threshold_per_m2 * c^2 (|a - b| > t, strictly). The paper's filter (a Kinect 2, t = 2 cm) is
/// threshold_per_m2 = 0; the quadratic term follows the depth resolution of triangulating sensors,
/// whose disparity steps grow with c^2 (Kinect v1: about 2.9 mm * c^2 per step, so at 3.5 m every
/// pixel differs from some neighbour by more than 2 cm and a fixed 2 cm removes whole walls).
/// - Decisions are made on the input: a removed pixel still counts as a neighbour of the others.
/// - Invalid neighbours (0) do not count: they carry no depth, so a hole next to a pixel is not a
///   discontinuity by itself (the paper's filter targets depth jumps between measured surfaces).
/// - Pixels on the image border compare with the neighbours they have.
/// - `threshold_m` <= 0 disables the filter (the output is a copy).
/// This is the fast version (row pointers, branch-free vectorisable inner loop; AVX2 rows when
/// the CPU has it, else those of remove_border_outliers_portable()); it equals the plain
/// per-pixel test oracle remove_border_outliers_reference() (tests/support) bit for bit.
void remove_border_outliers(const Image<float>& depth_m, float threshold_m, float threshold_per_m2,
                            Image<float>& out);

/// The baseline-target rows of remove_border_outliers() (SSE2 on x86-64): the fallback that runs
/// when the CPU lacks AVX2; the same bits. Exposed so that tests cover it on any machine.
void remove_border_outliers_portable(const Image<float>& depth_m, float threshold_m,
                                     float threshold_per_m2, Image<float>& out);

/// depth_to_metres() followed by remove_border_outliers() with config.outlier_threshold_m and
/// config.outlier_threshold_per_m2, fused into one pass over the frame; bit-for-bit equal to
/// calling the two in sequence. With `tracking_out`, the same pass also writes the depth filtered
/// with config.tracking_outlier_threshold_per_m2 instead there, or leaves it empty when the two
/// growths are equal (then `out` is that depth). Throws like depth_to_metres().
void preprocess_depth(const DepthFrame& frame, const PreprocessConfig& config, Image<float>& out,
                      Image<float>* tracking_out = nullptr);

/// Everything preprocessing produces for one frame; keep one per pipeline slot and refill it.
/// Tracking and fusion may read differently filtered depth (outlier_threshold_per_m2 and
/// tracking_outlier_threshold_per_m2).
struct PreprocessedFrame {
  Image<float>
      depth_m;  ///< metres, range-clipped, border outliers removed: fused; SSAO "raw" input
  /// depth_m with the tracking outlier threshold; empty when that is depth_m itself
  Image<float> tracking_m;
  Image<float> filtered_m;  ///< tracking_depth() after the bilateral filter
  DepthPyramid pyramid;     ///< tracking pyramid built from filtered_m with frame.intrinsics

  const Image<float>& tracking_depth() const { return tracking_m.empty() ? depth_m : tracking_m; }
};

/// The whole chain for one frame: preprocess_depth(), bilateral_filter(), build_pyramid() with
/// frame.intrinsics. Throws like depth_to_metres() and build_pyramid().
void preprocess_frame(const DepthFrame& frame, const PreprocessConfig& config,
                      PreprocessedFrame& out);

}  // namespace aoscan
