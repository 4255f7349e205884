/// @file geometry_reference.h
/// @brief Test oracle of the geometry module: the plain serial normal smoothing that
/// smooth_model_normals() is checked against.
#pragma once

#include "geometry/point_maps.h"

namespace aoscan {

/// Plain serial reference of smooth_model_normals(): smoothed_normal() at every pixel, the
/// vertices and intrinsics copied.
void smooth_model_normals_reference(const PointMaps& in, int radius_px, float max_distance_m,
                                    PointMaps& out);

}  // namespace aoscan
