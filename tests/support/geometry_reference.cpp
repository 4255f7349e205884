/// @file geometry_reference.cpp
/// @brief Plain serial reference of the normal smoothing.
#include "support/geometry_reference.h"

#include <algorithm>

#include "geometry/normal_smoothing.h"

namespace aoscan {

void smooth_model_normals_reference(const PointMaps& in, int radius_px, float max_distance_m,
                                    PointMaps& out) {
  out.intrinsics = in.intrinsics;
  out.vertices = in.vertices;
  out.normals.resize(in.vertices.width(), in.vertices.height(), Eigen::Vector3f::Zero());
  const float max_distance_sq = max_distance_m * max_distance_m;
  for (int y = 0; y < in.vertices.height(); ++y)
    for (int x = 0; x < in.vertices.width(); ++x)
      out.normals(x, y) = smoothed_normal(in, x, y, std::max(radius_px, 0), max_distance_sq);
}

}  // namespace aoscan
