/// @file synth_frames.h
/// @brief Frames of the synthetic corner orbit rendered on demand, with their exact poses, for
/// tests that build their own frame sequences (gaps, jumps, edited frames).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "core/depth_frame.h"
#include "sim/synth_camera.h"

namespace aoscan::test {

/// Frame `index` of the corner orbit (seed 3, 30 fps) at 320x240 with exact depth: the checks
/// are about bad input, not sensor noise. Rendered once, on demand (not thread-safe).
inline const DepthFrame& corner_frame(int index) {
  static std::map<int, DepthFrame> cache;
  auto it = cache.find(index);
  if (it != cache.end()) return it->second;
  static const AnalyticScene scene = AnalyticScene::make("corner");
  SynthParams params;
  params.scene = "corner";
  params.width = 320;
  params.height = 240;
  params.seed = 3;
  DepthFrame frame;
  render_synth_frame(scene, params, static_cast<std::uint64_t>(index), frame);
  frame.origin = "corner frame " + std::to_string(index);
  return cache.emplace(index, std::move(frame)).first->second;
}

}  // namespace aoscan::test
