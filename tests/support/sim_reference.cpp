/// @file sim_reference.cpp
/// @brief The synthetic depth camera's reference rendering, pixel by pixel.
#include "support/sim_reference.h"

namespace aoscan {

void render_synth_depth_reference(const AnalyticScene& scene, const Intrinsics& intrinsics,
                                  const Pose& T_world_camera, const SynthRenderOptions& options,
                                  Image<std::uint16_t>& depth) {
  depth.resize(intrinsics.width, intrinsics.height);
  for (int v = 0; v < intrinsics.height; ++v) {
    for (int u = 0; u < intrinsics.width; ++u)
      depth(u, v) = render_synth_depth_pixel(scene, intrinsics, T_world_camera, options, u, v);
  }
}

}  // namespace aoscan
