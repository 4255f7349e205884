/// @file synth_source.h
/// @brief The `synth:NAME?key=value&...` source: the synthetic depth camera of sim/ as a Source.
#pragma once

#include <memory>
#include <string>

#include "capture/source.h"
#include "sim/synth_camera.h"

namespace aoscan {

/// Opens a `synth:` spec as a Source: `size()` = frames, frame i has timestamp i / fps, sequence i,
/// origin "SPEC frame i", depth_scale 5000 and the exact pose; `scene_mesh()` is the scene's
/// to_mesh(); `name()` is the spec. Throws usage_error as parse_synth_spec.
std::unique_ptr<Source> open_synth_source(const std::string& spec);

}  // namespace aoscan
