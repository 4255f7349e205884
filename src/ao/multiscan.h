/// @file multiscan.h
/// @brief Multi-view AO integration of registered scans (Sabbadin et al. 2016 Sec. 5, Eq. 6-12):
/// every point of every scan takes the weighted average of the per-scan SSAO of the points that
/// the scans measured at its place.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/image.h"
#include "geometry/range_map.h"

namespace aoscan {

/// One scan ready for the integration: its range map (normals set), its own SSAO (in [0, 1],
/// 1 = open; the value of a pixel without a point is not read) and its border distance d_b in
/// pixels (border_distance()).
struct ScanAo {
  RangeMap map;
  Image<float> ssao;
  Image<float> border_px;
};

/// Parameters of the integration.
struct MultiScanParams {
  float d_min_m = 1.0f;       ///< Eq. 10: the scanner's minimum range (m)
  float d_max_m = 6.0f;       ///< Eq. 10: the largest depth of the scans (m)
  float t_p_px = 64.0f;       ///< Eq. 12: the border distance (pixels) at which w_b reaches 1
  bool border_weight = true;  ///< false: w_b = 1 (the ablation of Fig. 5)
  int neighbourhood = 1;      ///< N of the N x N samples per corresponding point (odd, 1..9)
  /// Scans whose world bounding boxes, grown by this margin (m), do not meet are not paired
  /// (they cannot share a point); the margin covers the 2t distance test (pair_margin()).
  float pair_margin_m = 0.05f;
};

/// What integrate_scans() did.
struct MultiScanStats {
  long long points = 0;             ///< points of all scans
  long long pairs_tested = 0;       ///< ordered scan pairs (i, j), i != j, whose boxes meet
  long long pairs_skipped = 0;      ///< ordered pairs skipped by the bounding-box test
  long long points_shared = 0;      ///< points with a sample from another scan in L_2
  std::vector<int> isolated_scans;  ///< scans that share a point with no other scan
};

/// World bounding box of a scan's points (empty when it has none).
Eigen::AlignedBox3f scan_world_box(const RangeMap& map);

/// Whether two scans with these world boxes may share a point: the boxes, one grown by
/// `margin_m`, meet.
bool scan_boxes_meet(const Eigen::AlignedBox3f& a, const Eigen::AlignedBox3f& b, float margin_m);

/// Eq. 6-7 for one point of scan i, `q` (metres) in scan j's frame, `rad_i` its point radius
/// there, `scanner_i` scanner i's position in scan j's frame: the pixel (px, py) of scan j whose
/// point p_ij joins L_2. p_ij is the point scan j measured at q's pixel or, when that pixel has
/// none (a hole of the map: a missed return, or a cloud rebuilt into the Sec. 7 map, which holds
/// a point in about half of its pixels), the point of its 8 neighbours nearest to q (ties to the
/// first in row order); it joins when it lies within 2 t of q and faces scanner i ((scanner_i -
/// p_ij) . n_ij > 0). t is the larger point radius of the two (point_radius()) or, where the
/// scans' range noise is larger, kNoiseMatchFactor times the noise of the two points together:
/// scan i's `noise_i` at the point's depth there, `depth_i`, and scan j's at p_ij's depth
/// (RangeMap::noise; 0 where unknown), so that a noisy camera's scans of one surface still find
/// each other.
bool corresponding_pixel(const RangeMap& map_j, const Eigen::Vector3f& q, float rad_i,
                         const ScanNoise& noise_i, float depth_i, const Eigen::Vector3f& scanner_i,
                         int& px, int& py);
/// The multiple of the two points' range noise, sqrt(sigma_i^2 + sigma_j^2), within which (times 2)
/// corresponding_pixel() accepts a point.
inline constexpr float kNoiseMatchFactor = 1.5f;
/// How far apart two scans' world boxes may lie and the scans still share a point:
/// params.pair_margin_m, or the reach of corresponding_pixel()'s noise test at the scans' largest
/// noise when that is farther.
float pair_margin(const MultiScanParams& params, const ScanNoise& a, const ScanNoise& b);

/// What the integration reads of each pixel of a candidate scan j besides its point and normal,
/// worked out once per scan instead of once per sample (a pixel is a sample of every point of
/// every scan i that lands near it): the view weight w_d w_n of Eq. 10-11 (view_weight(), 0 where
/// the pixel has no point), d_b rad(p_j) / t_p, which makes Eq. 12's w_b = min(d_b / (t_p alpha),
/// 1) = min(that / rad(p_i), 1) with alpha = rad(p_i) / rad(p_j), and the SSAO.
class MvaoSamples {
 public:
  MvaoSamples() = default;
  /// make(scan_j, params).
  MvaoSamples(const ScanAo& scan_j, const MultiScanParams& params);
  /// The samples of `scan_j` (the storage is reused). Throws usage_error for a scan whose images
  /// do not match its map.
  void make(const ScanAo& scan_j, const MultiScanParams& params);
  struct Sample {
    float weight;  ///< w_d w_n; 0: no point, or a sample that weighs nothing
    float border;  ///< d_b rad(p_j) / t_p (metres)
    float ssao;
  };
  const Sample& operator()(int x, int y) const {
    return samples_[static_cast<std::size_t>(y) * width_ + x];
  }
  int width() const { return width_; }
  int height() const { return height_; }
  /// Bytes held per pixel of scan j (for memory budgets).
  static constexpr std::size_t kBytesPerPixel = sizeof(Sample);

 private:
  int width_ = 0, height_ = 0;
  std::vector<Sample> samples_;
};

/// Eq. 6-9 for the points of one scan i, one candidate scan j at a time, so that a caller can hold
/// only scan i and the scan j it adds (the out-of-core path): each point p_i is taken into scan
/// j's frame (T_world_scanner_j^-1 T_world_scanner_i p_i), projected into its map, and the point
/// p_ij measured there joins L_2 by corresponding_pixel(). Each member of L_2 contributes the N x N
/// pixels around it in scan j's map (those with a point and a normal facing scanner i), each with
/// its SSAO weighted by w = w_d w_n w_b: w_d w_n of Eq. 10-11 for the sample seen from its own
/// scanner (view_weight()), w_b = min(d_b / (t_p alpha), 1) of Eq. 12 with alpha = rad(p_i) /
/// rad(sample) (both read from MvaoSamples). Adding the candidates in the same order gives the
/// same sums, bit for bit, whatever else is held in memory. Rows run in parallel; the result does
/// not depend on the thread count.
class MvaoAccumulator {
 public:
  /// Starts scan i (which must outlive the accumulator). Throws usage_error on a bad
  /// neighbourhood or a scan whose images do not match its map.
  MvaoAccumulator(const ScanAo& scan_i, const MultiScanParams& params);
  /// Adds candidate scan j with its samples (made with the same parameters; `same_scan`: j is
  /// scan i itself, whose samples do not make a point shared). Throws usage_error for a scan
  /// whose images do not match its map or samples of another size.
  void add(const ScanAo& scan_j, const MvaoSamples& samples_j, bool same_scan);
  /// MVAO(p_i), the weighted mean of the samples, into `mvao` (scan i's map size; a point whose
  /// samples all weigh 0 keeps its own SSAO; pixels without a point get 1). Returns the points
  /// with a sample from another scan.
  long long finish(Image<float>& mvao) const;
  /// Bytes held per pixel of scan i (for memory budgets).
  static constexpr std::size_t kBytesPerPixel = 2 * sizeof(double) + 1;

 private:
  const ScanAo& scan_i_;
  MultiScanParams params_;
  std::vector<double> ao_w_, w_;
  std::vector<std::uint8_t> other_scan_;
};

/// Every scan's MVAO with all the scans in memory: for each scan i, MvaoAccumulator over the scans
/// j (i itself included) whose boxes meet scan i's, in index order. `mvao[i]` takes scan i's map
/// size. Throws usage_error on a bad neighbourhood or a scan whose images do not match its map.
MultiScanStats integrate_scans(const std::vector<ScanAo>& scans, const MultiScanParams& params,
                               std::vector<Image<float>>& mvao);

}  // namespace aoscan
