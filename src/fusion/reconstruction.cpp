/// @file reconstruction.cpp
/// @brief Track, integrate, raycast.
#include "fusion/reconstruction.h"

#include "fusion/marching_cubes.h"

namespace aoscan {

Reconstruction::Reconstruction(const Config& config) : config_(config), volume_(config.fusion) {}

FusionStep Reconstruction::process(const PreprocessedFrame& frame, const Intrinsics& intrinsics,
                                   std::shared_ptr<RaycastResult> raycast_out,
                                   bool integrate) {
  FusionStep step;
  if (!model_) {
    step.new_model = true;
    step.status = TrackingStatus::kGood;
    step.T_world_camera = T_world_last_;
  } else {
    step.icp = icp(frame.pyramid, *model_, T_world_last_, config_.tracking, icp_workspace_);
    step.status = step.icp.status;
    step.T_world_camera = step.icp.status == TrackingStatus::kLost ? T_world_last_
                                                                    : step.icp.T_world_camera;
  }
  if (step.status == TrackingStatus::kLost) {
    ++frames_lost_;
    return step;
  }
  if (integrate || step.new_model) {
    step.integrate = volume_.integrate(frame.depth_m, intrinsics, step.T_world_camera);
    step.integrated = true;
  }
  T_world_last_ = step.T_world_camera;
  raycast(volume_, intrinsics, step.T_world_camera, config_.fusion, *raycast_out);
  model_ = std::move(raycast_out);
  return step;
}

void Reconstruction::reset() {
  volume_.reset();
  model_.reset();
  T_world_last_ = Pose();
}

TriangleMesh Reconstruction::extract_mesh() const {
  return aoscan::extract_mesh(volume_, static_cast<float>(config_.fusion.mesh_min_weight));
}

}  // namespace aoscan
