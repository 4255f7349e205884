/// @file reference_ao.cpp
/// @brief Stratified cosine-weighted ray-traced obscurance (Sabbadin et al. 2016 Eq. 1).
#include "sim/reference_ao.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace aoscan {

double reference_obscurance(const RayCaster& cast, const Eigen::Vector3d& p,
                            const Eigen::Vector3d& n, double t_max_m, int strata_per_axis,
                            double offset_m) {
  constexpr double kPi = 3.14159265358979323846;
  if (!p.allFinite() || !n.allFinite() || !(n.squaredNorm() > 0.0)) return 1.0;
  const Eigen::Vector3d normal = n.normalized();
  // Tangent frame: any unit vector perpendicular to the normal.
  const Eigen::Vector3d helper =
      std::abs(normal.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d tangent = normal.cross(helper).normalized();
  const Eigen::Vector3d bitangent = normal.cross(tangent);
  const Eigen::Vector3d origin = p + offset_m * normal;
  const int k = std::max(strata_per_axis, 1);
  double sum = 0.0;
  for (int i = 0; i < k; ++i) {
    const double u1 = (i + 0.5) / k;
    const double r = std::sqrt(u1);
    const double up = std::sqrt(1.0 - u1);
    for (int j = 0; j < k; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5) / k;
      const Eigen::Vector3d dir =
          (r * std::cos(phi) * tangent + r * std::sin(phi) * bitangent + up * normal).normalized();
      const std::optional<double> t = cast(origin, dir, t_max_m);
      if (!t || !(*t < t_max_m)) {
        sum += 1.0;
        continue;
      }
      const double u = std::clamp(*t / t_max_m, 0.0, 1.0);
      sum += u * u * (3.0 - 2.0 * u);
    }
  }
  return sum / (static_cast<double>(k) * k);
}

double pearson_r(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t n = std::min(a.size(), b.size());
  if (n < 2) return 0.0;
  double ma = 0.0, mb = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= static_cast<double>(n);
  mb /= static_cast<double>(n);
  double sab = 0.0, saa = 0.0, sbb = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0.0 && sbb > 0.0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

}  // namespace aoscan
