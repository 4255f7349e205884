/// @file jump_flood.h
/// @brief Distance fields on images by jump flooding (Rong & Tan 2006), and the border distance
/// d_b of a range map (Sabbadin et al. 2016 Eq. 12: Laplacian edges, the 0.95 percentile of their
/// histogram, the distance in pixels to the nearest of them).
#pragma once

#include <cstdint>

#include "core/image.h"
#include "geometry/range_map.h"

namespace aoscan {

/// Distance in pixels from every pixel to the nearest seed (`seeds` non-zero), by jump flooding
/// with steps width/2, width/4, ..., 1 and one more pass of step 1 (the "JFA+1" variant, which
/// removes most of plain JFA's rare errors). With `wrap_x` the image is a cylinder (an
/// equirectangular map: column width - 1 neighbours column 0). +infinity everywhere when there is
/// no seed. Rows run in parallel; the result does not depend on the thread count. Jump flooding is
/// approximate: a pixel may get a seed that is slightly farther than the nearest one (exact for
/// any single seed and for seeds on one line; tests state the tolerance against the exact
/// field). The interior of each pass's rows runs eight pixels per AVX2 vector where the CPU has
/// it, with the same result bit for bit; `simd` false keeps to the portable code (tests compare
/// the two).
void jump_flood_distance(const Image<std::uint8_t>& seeds, bool wrap_x, Image<float>& distance_px,
                         bool simd = true);

/// What border_distance() found.
struct BorderStats {
  float threshold = 0.0f;  ///< the Laplacian threshold used: the percentile or the noise floor
  long long edges = 0;     ///< edge pixels (seeds of the distance field)
};

/// d_b of Eq. 12 for every pixel of `map`: the Laplacian |4 D(x, y) - sum of the 4 neighbours| of
/// the map's depth D (a pixel without a point, or outside the map, reads 0, so holes and a pinhole
/// map's edge are borders; an equirectangular map has no edge: it wraps in azimuth and across its
/// poles, onto_map(); its distances are measured on the map, not across a pole) but for dropouts: a
/// pixel without a point that has one within kDropoutRadiusPx on both sides along its row or its
/// column, or one diagonally beside it on both sides (which takes in the corners of a 3 x 3 hole),
/// such as a depth camera's missed returns at grazing incidence or the gaps of a cloud rebuilt into
/// a map, reads the depth of the pixel beside it, the scan covering the surface around it; edges
/// are the pixels with a point whose Laplacian reaches the 0.95 percentile of the Laplacian over
/// the pixels with a point (nearest rank) and kBorderNoiseMedians times its median, and exceeds
/// min_edge_ratio times their own depth (both floors keep the noise of a smooth surface from being
/// taken as its "most valuable borders": the depth floor when the scan has no real discontinuity,
/// the median's when the range noise is larger than it); then the jump-flooding distance to the
/// nearest edge, in pixels. Pixels without a point get 0.
BorderStats border_distance(const RangeMap& map, float min_edge_ratio, Image<float>& distance_px);

/// How far (pixels) border_distance() looks on each side of a missing point for the points that
/// make it a dropout rather than a coverage border: 2 (gaps up to 3 pixels wide). On the multi-scan
/// benchmark, 1 gains half as much on the Kinect-noise sets, 3 costs the pinhole laser corner sets
/// 0.005 of r (their slivers between occluders are real borders).
inline constexpr int kDropoutRadiusPx = 2;

/// border_distance()'s noise floor, in medians of the map's Laplacian. The median is the range
/// noise's (|L| of Gaussian noise of sigma s has a median of about 3 s), a coverage border's
/// Laplacian is the depth of the surface beside a hole or the map's edge, or a depth jump. 24: on
/// the multi-scan benchmark's laser sets with 2 mm noise, w_b then raises the MVAO's r instead of
/// lowering it (12 and 48 give the same r to 0.003; without the floor, 3-4 % of the points were
/// noise edges); without noise it changes nothing (BENCHMARKS.md).
inline constexpr float kBorderNoiseMedians = 24.0f;

}  // namespace aoscan
