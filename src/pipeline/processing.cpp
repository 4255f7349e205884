/// @file processing.cpp
/// @brief The preprocess and track+integrate stages and the outputs they leave.
#include "pipeline/processing.h"

#include <filesystem>

#include "core/log.h"
#include "io/ply.h"

namespace aoscan {

Processing::Processing(const Config& config) : config_(config), reconstruction_(config) {}

std::vector<StageDef> Processing::stages() {
  return {
      {"preprocess", [this](FrameWork& frame) { return preprocess(frame); }},
      {"track", [this](FrameWork& frame) { return track(frame); }},
  };
}

Status Processing::preprocess(FrameWork& frame) const {
  preprocess_frame(frame.raw, config_.preprocess, frame.pre);
  return Status::ok();
}

Status Processing::track(FrameWork& frame) {
  if (reset_requested_.exchange(false)) {
    reconstruction_.reset();
    spdlog::info("model reset at frame {}", frame.raw.sequence);
  }
  std::shared_ptr<RaycastResult> raycast = raycasts_.acquire();
  frame.fusion = reconstruction_.process(frame.pre, frame.raw.intrinsics, raycast, !paused_.load());
  if (frame.fusion.status == TrackingStatus::kLost) {
    ++frames_tracking_lost_;
    frame.raycast.reset();
    spdlog::debug("frame {}: tracking lost ({} inliers)", frame.raw.sequence, frame.fusion.icp.inliers);
    return Status::ok();
  }
  frame.raycast = std::move(raycast);
  trajectory_.push_back({frame.raw.timestamp_s, frame.fusion.T_world_camera});
  return Status::ok();
}

Processing::ExportStats Processing::write_outputs(const std::string& out_dir) const {
  const std::filesystem::path dir(out_dir);
  write_trajectory((dir / "trajectory.txt").string(), trajectory_);
  const TriangleMesh mesh = reconstruction_.extract_mesh();
  write_ply((dir / "mesh.ply").string(), mesh);
  return {mesh.vertices.size(), mesh.faces.size()};
}

}  // namespace aoscan
