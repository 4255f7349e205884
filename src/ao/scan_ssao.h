/// @file scan_ssao.h
/// @brief Per-scan SSAO of a range map (Sabbadin et al. 2016 Sec. 4) for the multi-scan MVAO:
/// the real-time path's point estimators on any scan camera (pinhole or equirectangular), then
/// the paper's 5 x 5 Gaussian smoothing, no wider in metres than r_s / 10.
#pragma once

#include <cstdint>

#include "ao/ao_config.h"
#include "core/image.h"
#include "geometry/range_map.h"

namespace aoscan {

/// SSAO of every point of `map` (normals set): a screen-space disk of radius r_s *
/// pixels_per_metre_at_1m() / depth pixels (the paper's simplification: one radius per depth,
/// whatever the pixel's place in the map; on an equirectangular map the disk of that radius is laid
/// across the view ray and projected into the map, ScanCamera::SphereRow::offsets(), so that it
/// spans r_s both ways at every latitude and reaches across the seam and the poles), sampled by
/// make_ssao_pattern(config, pattern_index) at the nearest pixels (a sample in a hole of the map
/// reads the neighbouring pixel it leans to: a cloud's Sec. 7 map holds a point in about half of
/// its pixels); the sample terms of config.estimator as in compute_ssao() (paper, obscurance,
/// alchemy with its area factor over config.area_min_cos, read from the sample's own normal where
/// it has one; the slice estimators and statvo fall back to obscurance), the bias scaled by the
/// point's depth. Then smooth_scan_ssao() over kScanSsaoSmoothingShare * r_s (the paper's 5 x 5
/// Gaussian of sigma 1 px where a pixel spans that much or less). `ao` takes the map's size:
/// [0, 1], 1 = open; 1 where there is no point. Rows run in parallel; the result does not depend
/// on the thread count. `plane_offset_m` (empty, or the map's size; compute_scan_normals() returns
/// it): each point is read moved by it along its normal, onto the plane fitted to its neighbours,
/// so that a noisy scan's range noise does not pass for occluders.
void compute_scan_ssao(const RangeMap& map, const AoConfig& config, std::uint64_t pattern_index,
                       Image<float>& ao, const Image<float>& plane_offset_m = {});

/// The smoothing of compute_scan_ssao()'s per-pixel SSAO, as a share of r_s: sigma = r_s / 10.
inline constexpr double kScanSsaoSmoothingShare = 0.1;

/// The 5 x 5 Gaussian that compute_scan_ssao() runs over its per-pixel SSAO `raw` (the map's
/// size) into `ao`: over the pixels with a point and a normal, renormalised at holes and edges,
/// crossing an equirectangular map's seam and poles (onto_map()); 1 where there is no normal. The
/// paper smooths by sigma = 1 px; here a pixel whose footprint point_radius() exceeds `sigma_m`
/// is smoothed by sigma_m / footprint pixels instead, so that a coarse map (an 800 x 400 laser
/// map's pixel spans 2 cm at 2.5 m) is not blurred over more metres than a fine one.
void smooth_scan_ssao(const RangeMap& map, const Image<float>& raw, float sigma_m,
                      Image<float>& ao);

}  // namespace aoscan
