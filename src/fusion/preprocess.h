/// @file preprocess.h
/// @brief Depth preprocessing: raw units to metres, border-outlier removal (paper 000 Sec. 6),
/// bilateral filter, the 3-level tracking pyramid with vertex and normal maps (KinectFusion).
///
/// Conventions of the whole fusion module: depth images hold metres along the optical axis as
/// float, and 0.0f marks an invalid pixel. Every function here writes into a caller-owned output
/// image that is resized (without reallocating when it is already large enough), so per-frame code
/// can reuse its buffers. Outputs must not alias inputs. All functions are deterministic and give
/// the same result for any number of TBB threads.
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "core/config.h"
#include "core/depth_frame.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "fusion/point_maps.h"

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

/// Border-outlier removal of paper 000 Sec. 6: a valid pixel of depth c is removed (set to 0) when
/// any of its 8 neighbours differs from it in depth by more than t = threshold_m +
/// threshold_per_m2 * c^2 (|a - b| > t, strictly). The paper's filter (a Kinect 2, t = 2 cm) is
/// threshold_per_m2 = 0; the quadratic term follows the depth resolution of triangulating
/// sensors, whose disparity steps grow with c^2 (Kinect v1: about 2.9 mm * c^2 per step, so at
/// 3.5 m every pixel differs from some neighbour by more than 2 cm and a fixed 2 cm removes
/// whole walls).
/// - Decisions are made on the input: a removed pixel still counts as a neighbour of the others.
/// - Invalid neighbours (0) do not count: they carry no depth, so a hole next to a pixel is not a
///   discontinuity by itself (the paper's filter targets depth jumps between measured surfaces).
/// - Pixels on the image border compare with the neighbours they have.
/// - `threshold_m` <= 0 disables the filter (the output is a copy).
/// This is the fast version (row pointers, branch-free vectorisable inner loop); it equals
/// remove_border_outliers_reference() bit for bit.
void remove_border_outliers(const Image<float>& depth_m, float threshold_m, float threshold_per_m2,
                            Image<float>& out);

/// The baseline-target rows of remove_border_outliers() (SSE2 on x86-64), which run when the CPU
/// lacks AVX2; the same bits.
void remove_border_outliers_portable(const Image<float>& depth_m, float threshold_m,
                                     float threshold_per_m2, Image<float>& out);

/// Plain per-pixel scalar reference of remove_border_outliers() (same contract).
void remove_border_outliers_reference(const Image<float>& depth_m, float threshold_m,
                                      float threshold_per_m2, Image<float>& out);

/// depth_to_metres() followed by remove_border_outliers() with config.outlier_threshold_m and
/// config.outlier_threshold_per_m2, fused into one pass over the frame; bit-for-bit equal to
/// calling the two in sequence. With `tracking_out`, the same pass also writes the depth filtered
/// with config.tracking_outlier_threshold_per_m2 instead there, or leaves it empty when the two
/// growths are equal (then `out` is that depth). Throws like depth_to_metres().
void preprocess_depth(const DepthFrame& frame, const PreprocessConfig& config, Image<float>& out,
                      Image<float>* tracking_out = nullptr);

// ---------------------------------------------------------------------------------------------
// Bilateral filter
// ---------------------------------------------------------------------------------------------

/// Edge-preserving bilateral filter of a metric depth image (KinectFusion Sec. 3.2). For a valid
/// pixel p with depth z_p, over the (2 r + 1)^2 window (r = config.bilateral_radius_px):
///   out_p = z_p + sum_q w_q (z_q - z_p) / sum_q w_q,
///   w_q = exp(-|q - p|^2 / (2 sigma_space^2)) * exp(-(z_q - z_p)^2 / (2 sigma_depth^2)),
/// over valid q with |z_q - z_p| <= 3 sigma_depth (farther depths belong to another surface and
/// are ignored, so a step edge higher than 3 sigma_depth is preserved exactly). Writing the mean as
/// an offset from z_p keeps a constant depth exactly constant. Invalid pixels stay invalid and do
/// not contribute. A radius of 0 copies the input. This is the fast version (AVX2 + FMA over eight
/// pixels with the window's sums in registers when the CPU has them, else
/// bilateral_filter_portable(); TBB over rows); it agrees with bilateral_filter_reference() within
/// 1e-6 m, and its result does not depend on the thread count.
void bilateral_filter(const Image<float>& depth_m, const PreprocessConfig& config,
                      Image<float>& out);

/// The portable path of bilateral_filter() that runs when the CPU lacks AVX2 + FMA (SSE2 rows on
/// x86-64); same contract and tolerance. Exposed so that tests cover it on any machine.
void bilateral_filter_portable(const Image<float>& depth_m, const PreprocessConfig& config,
                               Image<float>& out);

/// Plain per-pixel scalar reference of bilateral_filter() (std::exp for every tap).
void bilateral_filter_reference(const Image<float>& depth_m, const PreprocessConfig& config,
                                Image<float>& out);

// ---------------------------------------------------------------------------------------------
// Pyramid, vertex and normal maps
// ---------------------------------------------------------------------------------------------

/// Halves a metric depth image: output pixel (x, y) averages the valid depths of the 2x2 block
/// (2x..2x+1, 2y..2y+1) that lie within `max_depth_diff_m` of the block's first valid depth in
/// raster order (KinectFusion-style: only depths of the same surface are averaged); 0 when the
/// block has no valid depth. Output size is (width / 2, height / 2), matching
/// Intrinsics::scaled(1); an odd last row or column is dropped.
void downsample_depth(const Image<float>& depth_m, float max_depth_diff_m, Image<float>& out);

/// Vertex map: the camera-frame point (metres) of every pixel, Intrinsics::unproject(x, y, z) with
/// `intrinsics` of this image's resolution; the zero vector where the depth is invalid.
void compute_vertex_map(const Image<float>& depth_m, const Intrinsics& intrinsics,
                        Image<Eigen::Vector3f>& vertices);

/// Normal map of a camera-frame vertex map: n = normalise((v(x+1,y) - v) x (v(x,y+1) - v)),
/// flipped so that it faces the camera (n . v < 0). The zero vector where the pixel or its right
/// or down neighbour is invalid (zero vertex), where either neighbour's z differs from the pixel's
/// by more than `max_depth_jump_m`, in the last column and last row, and where the cross product
/// vanishes.
void compute_normal_map(const Image<Eigen::Vector3f>& vertices, float max_depth_jump_m,
                        Image<Eigen::Vector3f>& normals);

/// compute_vertex_map() and compute_normal_map() in one pass over the depth image (the normal map
/// with `max_depth_jump_m`), `maps.intrinsics` = `intrinsics`. This is the fast version (AVX2 over
/// eight pixels when the CPU has it, TBB over rows); it performs the reference functions'
/// operations in their order without fused multiply-adds and equals them bit for bit in the
/// default build (within 1e-6 when the whole build uses FMA contraction, e.g. -march=native).
void compute_point_maps(const Image<float>& depth_m, const Intrinsics& intrinsics,
                        float max_depth_jump_m, PointMaps& maps);

/// Builds the tracking pyramid from a (bilateral-)filtered metric depth image of `intrinsics`'
/// resolution: level 0 is `filtered_m`, level l + 1 is downsample_depth() of level l with
/// config.pyramid_max_depth_diff_m; every level gets Intrinsics::scaled(l), its vertex map and its
/// normal map (jump threshold config.normal_max_depth_jump_m * 2^l) through compute_point_maps().
/// Throws input_error when the image size differs from intrinsics.width x intrinsics.height.
void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics,
                   const PreprocessConfig& config, DepthPyramid& out);

/// build_pyramid() with the default PreprocessConfig thresholds.
void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics, DepthPyramid& out);

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
