/// @file preprocess_reference.cpp
/// @brief Plain scalar references of the border-outlier removal and of the bilateral filter.
#include "support/preprocess_reference.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace aoscan {

void remove_border_outliers_reference(const Image<float>& depth_m, float threshold_m,
                                      float threshold_per_m2, Image<float>& out) {
  out = depth_m;
  if (!(threshold_m > 0.0f)) return;  // a threshold that is not positive disables the filter
  for (int y = 0; y < depth_m.height(); ++y) {
    for (int x = 0; x < depth_m.width(); ++x) {
      const float c = depth_m(x, y);
      const float t = threshold_m + threshold_per_m2 * c * c;
      bool remove = !(c > 0.0f);
      for (int dy = -1; dy <= 1 && !remove; ++dy) {
        for (int dx = -1; dx <= 1 && !remove; ++dx) {
          if ((dx == 0 && dy == 0) || !depth_m.contains(x + dx, y + dy)) continue;
          const float n = depth_m(x + dx, y + dy);
          if (n > 0.0f && std::fabs(c - n) > t) remove = true;
        }
      }
      if (remove) out(x, y) = 0.0f;
    }
  }
}

void bilateral_filter_reference(const Image<float>& depth_m, const PreprocessConfig& config,
                                Image<float>& out) {
  // The filter's constants as bilateral_filter() derives them: the radius within the range the
  // configuration accepts, sigmas clamped away from zero so that the weights stay finite.
  const int radius = std::clamp(config.bilateral_radius_px, 0, 16);
  if (radius == 0) {
    out = depth_m;
    return;
  }
  const double sd = std::max(config.bilateral_sigma_depth_m, 1e-6);
  const float neg_inv_two_sigma_depth_sq = static_cast<float>(-1.0 / (2.0 * sd * sd));
  const float cutoff_m = static_cast<float>(3.0 * sd);
  const double ss = std::max(config.bilateral_sigma_space_px, 1e-3);
  const int side = 2 * radius + 1;
  std::vector<float> spatial(static_cast<std::size_t>(side) * side);
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx)
      spatial[(dy + radius) * side + dx + radius] =
          static_cast<float>(std::exp(-(dx * dx + dy * dy) / (2.0 * ss * ss)));

  const int w = depth_m.width();
  const int h = depth_m.height();
  out.resize(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float c = depth_m(x, y);
      if (!(c > 0.0f)) {
        out(x, y) = 0.0f;
        continue;
      }
      float sum = 0.0f;
      float weight = 0.0f;
      for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
          if (!depth_m.contains(x + dx, y + dy)) continue;
          const float n = depth_m(x + dx, y + dy);
          const float d = n - c;
          if (!(n > 0.0f) || std::fabs(d) > cutoff_m) continue;
          const float wq = spatial[(dy + radius) * side + dx + radius] *
                           std::exp(d * d * neg_inv_two_sigma_depth_sq);
          sum += wq * d;
          weight += wq;
        }
      }
      out(x, y) = c + sum / weight;
    }
  }
}

}  // namespace aoscan
