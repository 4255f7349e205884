/// @file sim_reference.h
/// @brief Test oracle of the sim module: the synthetic depth camera rendered on one thread, pixel
/// by pixel, without tile culling.
#pragma once

#include <cstdint>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "sim/synth_camera.h"
#include "sim/synth_scene.h"

namespace aoscan {

/// The same as render_synth_depth on one thread, pixel by pixel (render_synth_depth_pixel(), every
/// ray tested against every primitive): the reference implementation.
void render_synth_depth_reference(const AnalyticScene& scene, const Intrinsics& intrinsics,
                                  const Pose& T_world_camera, const SynthRenderOptions& options,
                                  Image<std::uint16_t>& depth);

}  // namespace aoscan
