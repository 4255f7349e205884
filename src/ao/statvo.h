/// @file statvo.h
/// @brief Statistical volumetric obscurance with adaptive depth layers and summed-area tables
/// (Hendrickx, Scandolo, Eisemann, Eisemann 2015, in the Harvest4D deliverable D8.11): the
/// `statvo` SSAO estimator, one box average per layer instead of N point samples.
///
/// Per pixel p (camera frame, SSAO normal n), the sample box is the screen rectangle of half
/// size round(fx r_s / z) x round(fy r_s / z) pixels around p (capped as the point estimators'
/// disk), clipped to the image. The valid pixels are split into four layers by two adaptive
/// partitions (Sec. 5): a pixel q goes to the far half of its layer when z_q lies at least 0.1 um
/// beyond the mean depth of that layer's pixels in q's own box, else to the near half (all valid
/// pixels, then each half again). Per layer i the box gives the count n_i and the mean position m_i
/// of its pixels (from the layer's summed-area table of (x, y, z, 1); the far halves as
/// differences, Sec. 7.2), and the oriented obscurance (Sec. 6, Eq. 6-7) is
///   O_i = psi(((m_i - p) . n - beta z) / r_s),
/// psi(u) = 0 for u <= 0, u on [0, 1], then falling linearly to 0 at u = 1 + t_max / r_s (a layer
/// whose mean lies far above the box, e.g. a foreground object, does not occlude). The pixel's AO
/// is 1 - sum(O_i n_i) / sum(n_i) (Eq. 5), and its coverage (for the coverage weight) is
/// sum(n_i) / the unclipped box's pixel count. beta = ao.bias as for the point estimators.
/// The tables are full resolution and in double precision (exact counts, sums of positions
/// without the cancellation of 32-bit tables).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "ao/ao_config.h"
#include "geometry/point_maps.h"

namespace aoscan {
namespace detail {
struct FrameSetup;
struct PixelAo;
}  // namespace detail

/// The layered summed-area tables of one frame: S0 of every valid pixel, S10 of the near half,
/// S20 and S22 of the near halves of the two halves (the other layers are differences).
/// Each table is (width + 1) x (height + 1), entry (i, j) = the sum of (x, y, z, 1) over the
/// layer's pixels u < i, v < j. Reused across frames (buffers kept).
struct StatVoTables {
  int width = 0, height = 0;
  std::vector<Eigen::Vector4d> s0, s10, s20, s22;
  std::vector<std::uint8_t> layer;  ///< scratch: each pixel's layer (255 = invalid)
};

/// Builds the four layers' tables of `maps` (their vertices; valid = ssao_pixel_valid()).
void build_statvo_tables(const PointMaps& maps, const AoConfig& config, StatVoTables& tables);

/// The AO and coverage of pixel (x, y) with vertex p and SSAO normal n from `tables` (the frame's
/// constants in `setup`; see ssao_kernels.h).
detail::PixelAo statvo_pixel_ao(const StatVoTables& tables, const detail::FrameSetup& setup, int x,
                                int y, const Eigen::Vector3f& p, const Eigen::Vector3f& n);

}  // namespace aoscan
