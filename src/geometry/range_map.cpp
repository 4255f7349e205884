/// @file range_map.cpp
/// @brief Range maps from depth images and point clouds, and their normals.
#include "geometry/range_map.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Eigenvalues>
#include <string>

#include "core/status.h"

namespace aoscan {

long long RangeMap::count_points() const {
  long long n = 0;
  for (int y = 0; y < points.height(); ++y)
    for (int x = 0; x < points.width(); ++x) n += has_point(x, y) ? 1 : 0;
  return n;
}

void range_map_from_depth(const Image<float>& depth_m, const Intrinsics& intrinsics,
                          RangeMap& map) {
  if (depth_m.width() != intrinsics.width || depth_m.height() != intrinsics.height)
    throw input_error(map.name + ": depth image is " + std::to_string(depth_m.width()) + "x" +
                      std::to_string(depth_m.height()) + " but its intrinsics say " +
                      std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  map.camera = ScanCamera::make_pinhole(intrinsics);
  map.points.resize(intrinsics.width, intrinsics.height, Eigen::Vector3f::Zero());
  map.normals.resize(intrinsics.width, intrinsics.height, Eigen::Vector3f::Zero());
  for (int y = 0; y < intrinsics.height; ++y)
    for (int x = 0; x < intrinsics.width; ++x) {
      const float z = depth_m(x, y);
      map.points(x, y) = z > 0.0f && std::isfinite(z)
                             ? intrinsics.unproject(static_cast<float>(x), static_cast<float>(y), z)
                             : Eigen::Vector3f::Zero();
      map.normals(x, y).setZero();
    }
}

long long rasterize_points(const std::vector<Eigen::Vector3f>& points,
                           const std::vector<Eigen::Vector3f>& normals, RangeMap& map) {
  if (!map.camera.valid()) throw usage_error(map.name + ": the scan's camera is not usable");
  const bool with_normals = !normals.empty();
  if (with_normals && normals.size() != points.size())
    throw input_error(map.name + ": " + std::to_string(points.size()) + " points but " +
                      std::to_string(normals.size()) + " normals");
  map.points.resize(map.camera.width, map.camera.height, Eigen::Vector3f::Zero());
  map.normals.resize(map.camera.width, map.camera.height, Eigen::Vector3f::Zero());
  map.points.fill(Eigen::Vector3f::Zero());
  map.normals.fill(Eigen::Vector3f::Zero());
  // The projections (the costly part: two arc tangents a point for a laser scan) in parallel,
  // then the nearest-point test in input order, so that ties go to the first point as before.
  const std::size_t n = points.size();
  std::vector<std::int64_t> pixel(n);
  std::vector<float> depth(n);
  const int width = map.camera.width;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        int x = 0, y = 0;
                        if (!map.camera.pixel_of(points[i], x, y)) {
                          pixel[i] = -1;
                          continue;
                        }
                        pixel[i] = static_cast<std::int64_t>(y) * width + x;
                        depth[i] = map.camera.depth(points[i]);
                      }
                    });
  Image<float> nearest(map.camera.width, map.camera.height, 0.0f);  // depth of the point kept
  long long skipped = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (pixel[i] < 0) {
      ++skipped;
      continue;
    }
    const int x = static_cast<int>(pixel[i] % width), y = static_cast<int>(pixel[i] / width);
    const Eigen::Vector3f& p = points[i];
    if (map.has_point(x, y) && !(depth[i] < nearest(x, y))) continue;
    map.points(x, y) = p;
    nearest(x, y) = depth[i];
    if (with_normals) {
      Eigen::Vector3f normal = normals[i];
      const float length = normal.norm();
      normal = length > 0.0f && std::isfinite(length) ? Eigen::Vector3f(normal / length)
                                                      : Eigen::Vector3f::Zero();
      if (normal.dot(p) > 0.0f) normal = -normal;  // face the scanner
      map.normals(x, y) = normal;
    }
  }
  return skipped;
}

namespace {

/// What a plane fit leaves per pixel beside the normal (either may be null): the root of the
/// covariance's least eigenvalue, the points' spread along the normal (m), and the signed
/// distance along the normal from the pixel's point to the fitted plane through the points'
/// centroid (m).
struct PlaneFitOutputs {
  Image<float>* residual_m = nullptr;
  Image<float>* offset_m = nullptr;
};

/// The window radius (pixels) of a fit at `depth_m` over `support_m` metres: radius_px, or the
/// pixels support_m spans there when more, at most max_radius.
int window_radius(const ScanCamera& camera, float depth_m, float support_m, int radius_px,
                  int max_radius) {
  if (!(support_m > 0.0f)) return radius_px;
  const float pixels = support_m / point_radius(camera, depth_m);
  if (!(pixels > static_cast<float>(radius_px))) return radius_px;
  return pixels >= static_cast<float>(max_radius) ? max_radius
                                                  : static_cast<int>(std::ceil(pixels));
}

/// The offsets of a fit window along one axis for radius r: every pixel within r, or (a wide
/// metric support, r > dense_radius) 7 spread evenly over it, so that a window costs at most 7 x 7
/// reads. Rebuilt only when r changes.
class WindowAxis {
 public:
  const std::vector<int>& offsets(int r, int dense_radius) {
    if (r == r_) return offsets_;
    r_ = r;
    offsets_.clear();
    if (r <= dense_radius) {
      for (int d = -r; d <= r; ++d) offsets_.push_back(d);
    } else {
      constexpr int k = kDenseNormalRadiusPx;
      for (int i = -k; i <= k; ++i)
        offsets_.push_back(static_cast<int>(std::lround(static_cast<double>(i * r) / k)));
    }
    return offsets_;
  }

 private:
  int r_ = -1;
  std::vector<int> offsets_;
};

/// fit_normals()'s choice of the pixels that have no normal yet.
auto without_normal(const RangeMap& map) {
  return [&map](int x, int y) {
    const Eigen::Vector3f& n = map.normals(x, y);
    return n.x() == 0.0f && n.y() == 0.0f && n.z() == 0.0f;
  };
}

/// compute_range_map_normals() of the pixels with a point for which fit(x, y) holds, with the
/// support given per depth: support_of(depth) metres, the window's radius at most
/// max(radius_px, max_radius_px). A pixel whose fit fails keeps its normal.
/// With `crease_noise`, a window whose points spread along its normal by more than
/// kCreaseSpreadFactor times that noise at the pixel's depth straddles a crease or an edge: the
/// four windows of the same size shifted by their radius along the row and the column (the pixel
/// on their edge) are fitted too, and the fit kept is the one whose spread plus the square of the
/// pixel's own distance to its plane is the least (a window on one side of a crease holds a
/// plane, and that plane is the pixel's when the pixel lies on it).
template <typename Fit, typename SupportOf>
void fit_normals(RangeMap& map, const Fit& fit, float max_jump_ratio, int radius_px,
                 const SupportOf& support_of, int min_points, const PlaneFitOutputs& outputs,
                 int max_radius_px = kMaxNormalRadiusPx, const ScanNoise* crease_noise = nullptr) {
  const int w = map.points.width(), h = map.points.height();
  const bool wrap = map.camera.wraps();
  const int max_radius = std::max(radius_px, max_radius_px);
  const int dense_radius = std::max(radius_px, kDenseNormalRadiusPx);
  // Each pixel reads only points and writes only its own normal: rows run in parallel.
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    WindowAxis along_y, along_x;
    for (int y = rows.begin(); y < rows.end(); ++y) {
      // Off an equirectangular map's equator a row's pixels are narrower than its columns': the
      // window widens along the row so that it spans as many metres both ways (on a row near a
      // pole a square window is a strip of one ring of latitude, whose points lie nearly on a
      // line and leave the plane to the noise).
      const double stretch = map.camera.row_stretch(y);
      const auto width_of = [&](int radius) {
        if (stretch == 1.0) return radius;
        return static_cast<int>(
            std::min(std::lround(radius * stretch), static_cast<long>((w - 1) / 2)));
      };
      for (int x = 0; x < w; ++x) {
        if (!map.has_point(x, y) || !fit(x, y)) continue;
        const Eigen::Vector3f& p = map.points(x, y);
        const float depth = map.camera.depth(p);
        const int radius =
            window_radius(map.camera, depth, support_of(depth), radius_px, max_radius);
        // Neighbours on the same surface, centred on p for a well-conditioned covariance; the
        // window grows ring by ring (ring r: the pixels at Chebyshev distance r).
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
        int count = 0;
        const auto add = [&](int dx, int dy) {
          int sx = x + dx;
          int sy = y + dy;
          if (!onto_map(sx, sy, w, h, wrap) || !map.has_point(sx, sy)) return;
          const Eigen::Vector3f& q = map.points(sx, sy);
          if (std::abs(map.camera.depth(q) - depth) > max_jump_ratio * depth) return;
          const Eigen::Vector3d d = (q - p).cast<double>();
          sum += d;
          outer += d * d.transpose();
          ++count;
        };
        // The window of radius r centred (ox, oy) pixels from p.
        const auto window = [&](int r, int ox, int oy) {
          for (const int dy : along_y.offsets(r, dense_radius))
            for (const int dx : along_x.offsets(width_of(r), dense_radius)) add(dx + ox, dy + oy);
        };
        window(radius, 0, 0);
        if (width_of(radius) == radius) {
          for (int r = radius + 1; count < min_points && r <= max_radius; ++r) {
            for (int d = -r; d <= r; ++d) {
              add(d, -r);
              add(d, r);
            }
            for (int d = -r + 1; d <= r - 1; ++d) {
              add(-r, d);
              add(r, d);
            }
          }
        } else {  // a widened window grows as a whole, its width with its height
          for (int r = radius + 1; count < min_points && r <= max_radius; ++r) {
            sum.setZero();
            outer.setZero();
            count = 0;
            window(r, 0, 0);
          }
        }
        // The plane of the points gathered (their centroid `m`, relative to p): false when they
        // are fewer than three or on a line, which leave it undetermined.
        using Solver = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>;
        const auto solve = [&](Solver& e, Eigen::Vector3d& m) {
          if (count < 3) return false;
          m = sum / count;
          e.computeDirect(outer / count - m * m.transpose());
          const Eigen::Vector3d& values = e.eigenvalues();  // ascending
          return values(1) > 1e-6 * values(2);
        };
        Solver eigen;
        Eigen::Vector3d mean;
        if (!solve(eigen, mean)) continue;
        if (crease_noise != nullptr) {
          const double limit = kCreaseSpreadFactor * crease_noise->sigma(depth);
          if (eigen.eigenvalues()(0) > limit * limit) {
            const auto misfit = [](const Solver& e, const Eigen::Vector3d& m) {
              const double offset = e.eigenvectors().col(0).dot(m);
              return e.eigenvalues()(0) + offset * offset;
            };
            double best = misfit(eigen, mean);
            static constexpr int kShifts[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
            for (const auto& shift : kShifts) {
              sum.setZero();
              outer.setZero();
              count = 0;
              window(radius, shift[0] * width_of(radius), shift[1] * radius);
              Solver e;
              Eigen::Vector3d m;
              if (count < min_points || !solve(e, m)) continue;
              const double f = misfit(e, m);
              if (!(f < best)) continue;
              best = f;
              eigen = e;
              mean = m;
            }
          }
        }
        const Eigen::Vector3d& values = eigen.eigenvalues();  // ascending
        Eigen::Vector3f c = eigen.eigenvectors().col(0).cast<float>();
        if (!c.allFinite()) continue;
        if (c.dot(p) > 0.0f) c = -c;
        Eigen::Vector3f& n = map.normals(x, y);
        n = c.normalized();
        if (outputs.residual_m != nullptr)
          (*outputs.residual_m)(x, y) = static_cast<float>(std::sqrt(std::max(values(0), 0.0)));
        if (outputs.offset_m != nullptr)
          (*outputs.offset_m)(x, y) = static_cast<float>(n.cast<double>().dot(mean));
      }
    }
  });
}

/// The spread of a scan's points along their normals as a function of depth: the median of the
/// plane fits' residuals (the pixels whose residual is not negative) in kBins depth bins spaced
/// evenly in log depth between the nearest and the farthest fitted point, each bin's median read
/// from a histogram of kBucketsPerDecade buckets a decade (about 7 % apart) from kMinResidualM
/// up. A bin with fewer than kMinSamples fits, or less than 1/kMinShareInverse of them, takes the
/// value of the nearest bin that has them; a map with no such bin has sigma 0 everywhere. Medians,
/// so that the fits across creases and depth jumps, a minority, do not count; the share, so that a
/// room's farthest points, its corners (creases all), make no bin of their own. Memory: the
/// histograms only, whatever the map's size.
ScanNoise measure_depth_noise(const RangeMap& map, const Image<float>& residual_m) {
  constexpr int kBins = ScanNoise::kBins;
  constexpr long long kMinSamples = 256;
  constexpr long long kMinShareInverse = 256;  // and at least 1/256 of all the fits
  constexpr int kBucketsPerDecade = 32;
  constexpr float kMinResidualM = 1e-5f;
  constexpr int kBuckets = 5 * kBucketsPerDecade;  // up to 1 m
  ScanNoise noise;
  const int w = map.points.width(), h = map.points.height();
  float log_lo = std::numeric_limits<float>::infinity(), log_hi = -log_lo;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (residual_m(x, y) >= 0.0f) {
        const float d = std::log(map.camera.depth(map.points(x, y)));
        log_lo = std::min(log_lo, d);
        log_hi = std::max(log_hi, d);
      }
  if (!(log_lo <= log_hi)) return noise;
  noise.log_lo = log_lo;
  noise.bin_per_log = log_hi > log_lo ? kBins / (log_hi - log_lo) : 0.0f;
  std::vector<long long> counts(static_cast<std::size_t>(kBins) * kBuckets, 0);
  std::array<long long, kBins> totals{};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float r = residual_m(x, y);
      if (!(r >= 0.0f)) continue;
      const int b = noise.bin(map.camera.depth(map.points(x, y)));
      const float k = std::log10(std::max(r, kMinResidualM) / kMinResidualM) * kBucketsPerDecade;
      const int bucket = k >= kBuckets - 1 ? kBuckets - 1 : static_cast<int>(k);
      ++counts[static_cast<std::size_t>(b) * kBuckets + bucket];
      ++totals[b];
    }
  long long all = 0;
  for (const long long t : totals) all += t;
  const long long enough = std::max(kMinSamples, all / kMinShareInverse);
  std::array<bool, kBins> known{};
  for (int b = 0; b < kBins; ++b) {
    if (totals[b] < enough) continue;
    long long seen = 0;
    int bucket = 0;
    while (bucket < kBuckets - 1 &&
           (seen += counts[static_cast<std::size_t>(b) * kBuckets + bucket]) <= totals[b] / 2)
      ++bucket;
    noise.sigma_m[b] = kMinResidualM * std::pow(10.0f, (bucket + 0.5f) / kBucketsPerDecade);
    known[b] = true;
  }
  for (int b = 0; b < kBins; ++b) {
    if (known[b]) continue;
    for (int d = 1; d < kBins; ++d) {
      if (b - d >= 0 && known[b - d]) {
        noise.sigma_m[b] = noise.sigma_m[b - d];
        break;
      }
      if (b + d < kBins && known[b + d]) {
        noise.sigma_m[b] = noise.sigma_m[b + d];
        break;
      }
    }
  }
  return noise;
}

}  // namespace

void compute_range_map_normals(RangeMap& map, float max_jump_ratio, int radius_px, float support_m,
                               int min_points) {
  fit_normals(
      map, without_normal(map), max_jump_ratio, radius_px, [support_m](float) { return support_m; },
      min_points, PlaneFitOutputs{});
}

Image<float> compute_scan_normals(RangeMap& map) {
  const int w = map.points.width(), h = map.points.height();
  constexpr int kRadiusPx = 2;
  Image<float> residual(w, h, -1.0f);  // -1: not fitted here (no point, or a normal given)
  const auto floor = [](float) { return kScanNormalSupportM; };
  fit_normals(map, without_normal(map), kScanNormalMaxJumpRatio, kRadiusPx, floor,
              kScanNormalMinPoints, PlaneFitOutputs{&residual, nullptr});
  map.noise = measure_depth_noise(map, residual);
  const auto support = [&map](float depth_m) {
    return std::max(kScanNormalSupportM, kNoiseSupportFactor * map.noise.sigma(depth_m));
  };
  // The pixels fitted above whose support the noise widens are fitted again over it, and get the
  // offset to that fit's plane (even where the window already had its largest size: the offset
  // is the denoising).
  const auto widened = [&](int x, int y) {
    return residual(x, y) >= 0.0f &&
           support(map.camera.depth(map.points(x, y))) > kScanNormalSupportM;
  };
  bool any = false;
  for (int y = 0; y < h && !any; ++y)
    for (int x = 0; x < w && !any; ++x) any = widened(x, y);
  if (!any) return {};
  Image<float> offset(w, h, 0.0f);
  fit_normals(map, widened, kScanNormalMaxJumpRatio, kRadiusPx, support, kScanNormalMinPoints,
              PlaneFitOutputs{nullptr, &offset}, kMaxNoiseNormalRadiusPx, &map.noise);
  return offset;
}

}  // namespace aoscan
