/// @file reference_ao.h
/// @brief Ray-traced reference obscurance (Sabbadin et al. 2016 Eq. 1) at a surface point, for
/// measuring the screen-space estimators against ground truth.
///
/// Kept independent of any scene type (the ao module depends on core only): the caller passes a
/// ray caster, e.g. a lambda around capture's AnalyticScene::intersect.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace aoscan {

/// Distance (metres) along the unit `direction` from `origin` to the first surface hit within
/// (0, t_max], or nullopt when nothing is hit (world frame).
using RayCaster = std::function<std::optional<double>(
    const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_max)>;

/// Eq. 1 obscurance at world point `p` with unit normal `n` (metres, world frame):
/// O = (1/pi) int rho(d(w)) (n.w) dw with rho = smoothstep(0, t_max, d) and rho = 1 when nothing
/// is hit within t_max. Evaluated with strata_per_axis^2 deterministic cosine-weighted directions
/// (stratum midpoints of (u1, u2) mapped by r = sqrt(u1), phi = 2 pi u2), so the 1/pi and n.w
/// cancel and O is the mean of rho. Rays start at p + offset_m * n. Returns a value in [0, 1]
/// (1 = open); 1 for a non-finite point or normal.
double reference_obscurance(const RayCaster& cast, const Eigen::Vector3d& p,
                            const Eigen::Vector3d& n, double t_max_m, int strata_per_axis = 16,
                            double offset_m = 1e-6);

/// Pearson correlation of an estimate `a` with a reference `b` over their first min(|a|, |b|)
/// values: 0 when there are fewer than two or either is constant.
double pearson_r(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace aoscan
