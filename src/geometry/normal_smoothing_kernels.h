/// @file normal_smoothing_kernels.h
/// @brief Internal to the geometry module: the AVX2 row kernel of smooth_model_normals()
/// (normal_smoothing_avx2.cpp); both paths share smoothed_normal() (normal_smoothing.h).
#pragma once

#include <Eigen/Core>

#include "geometry/normal_smoothing.h"
#include "geometry/point_maps.h"
#include "geometry/simd.h"

namespace aoscan::smoothing_detail {

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_SMOOTHING_AVX2 1
/// Smoothed normals of row y into `row` (width pixels), for a row whose windows lie inside the
/// image vertically (radius_px <= y < height - radius_px) and an image at least 2 radius_px + 8
/// wide: eight pixels at a time with AVX2 + FMA from `planes` (the maps as six float planes vx,
/// vy, vz, nx, ny, nz of width * height each) where the window lies inside the image, the
/// radius_px pixels at each side and the leftover through smoothed_normal(); bit for bit
/// smoothed_normal() everywhere. Only for a CPU with AVX2 and FMA (cpu_has_avx2_fma()).
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT void smooth_row_avx2(
    const PointMaps& in, const float* planes, int y, int radius_px, float max_distance_sq,
    Eigen::Vector3f* row);
#endif

}  // namespace aoscan::smoothing_detail
