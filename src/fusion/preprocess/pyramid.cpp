/// @file pyramid.cpp
/// @brief The tracking pyramid: every level's depth, vertex map and normal map.
#include "fusion/preprocess/pyramid.h"

#include <string>

#include "core/status.h"

namespace aoscan {

void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics,
                   const PreprocessConfig& config, DepthPyramid& out) {
  if (filtered_m.width() != intrinsics.width || filtered_m.height() != intrinsics.height) {
    throw input_error("build_pyramid: depth image is " + std::to_string(filtered_m.width()) + "x" +
                      std::to_string(filtered_m.height()) + " but the intrinsics say " +
                      std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  }
  const float max_diff = static_cast<float>(config.pyramid_max_depth_diff_m);
  float jump = static_cast<float>(config.normal_max_depth_jump_m);
  out.depth_m[0] = filtered_m;
  for (int level = 0; level < kPyramidLevels; ++level) {
    if (level > 0) downsample_depth(out.depth_m[level - 1], max_diff, out.depth_m[level]);
    compute_point_maps(out.depth_m[level], intrinsics.scaled(level), jump, out.maps[level]);
    jump *= 2.0f;
  }
}

void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics,
                   DepthPyramid& out) {
  build_pyramid(filtered_m, intrinsics, PreprocessConfig{}, out);
}

}  // namespace aoscan
