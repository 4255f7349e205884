/// @file scan_ssao.h
/// @brief Per-scan SSAO of a range map (Sabbadin et al. 2016 Sec. 4) for the multi-scan MVAO:
/// the real-time path's point estimators on any scan camera (pinhole or equirectangular), then
/// the paper's 5 x 5 Gaussian smoothing.
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
/// alchemy without the area factor; the slice estimators and statvo fall back to obscurance), the
/// bias scaled by the point's depth. Then a 5 x 5 Gaussian (sigma 1 px) over the pixels with a
/// point. `ao` takes the map's size: [0, 1], 1 = open; 1 where there is no point. Rows run in
/// parallel; the result does not depend on the thread count. `plane_offset_m` (empty, or the map's
/// size; compute_scan_normals() returns it): each point is read moved by it along its normal, onto
/// the plane fitted to its neighbours, so that a noisy scan's range noise does not pass for
/// occluders.
void compute_scan_ssao(const RangeMap& map, const AoConfig& config, std::uint64_t pattern_index,
                       Image<float>& ao, const Image<float>& plane_offset_m = {});

}  // namespace aoscan
