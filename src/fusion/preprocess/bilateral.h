/// @file bilateral.h
/// @brief Edge-preserving bilateral filter of metric depth before tracking (KinectFusion Sec. 3.2).
#pragma once

#include "core/image.h"
#include "fusion/preprocess/preprocess_config.h"

namespace aoscan {

/// Edge-preserving bilateral filter of a metric depth image (KinectFusion Sec. 3.2). For a valid
/// pixel p with depth z_p, over the (2 r + 1)^2 window (r = config.bilateral_radius_px):
///   out_p = z_p + sum_q w_q (z_q - z_p) / sum_q w_q,
///   w_q = exp(-|q - p|^2 / (2 sigma_space^2)) * exp(-(z_q - z_p)^2 / (2 sigma_depth^2)),
/// over valid q with |z_q - z_p| <= 3 sigma_depth (farther depths belong to another surface and
/// are ignored, so a step edge higher than 3 sigma_depth is preserved exactly). Writing the mean as
/// an offset from z_p keeps a constant depth exactly constant. Invalid pixels stay invalid and do
/// not contribute. A radius of 0 copies the input. This is the fast version (AVX2 + FMA over eight
/// pixels with the window's sums in registers when the CPU has them, else
/// bilateral_filter_portable(); TBB over rows); it agrees with the plain per-pixel test oracle
/// bilateral_filter_reference() (tests/support) within 1e-6 m, and its result does not depend on
/// the thread count.
void bilateral_filter(const Image<float>& depth_m, const PreprocessConfig& config,
                      Image<float>& out);

/// The portable path of bilateral_filter(): the fallback that runs when the CPU lacks AVX2 + FMA
/// (SSE2 rows on x86-64); same contract and tolerance. Exposed so that tests cover it on any
/// machine.
void bilateral_filter_portable(const Image<float>& depth_m, const PreprocessConfig& config,
                               Image<float>& out);

}  // namespace aoscan
