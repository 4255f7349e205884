/// @file reconstruction.cpp
/// @brief Track, integrate, raycast.
#include "fusion/reconstruction.h"

#include <algorithm>
#include <atomic>
#include <optional>

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fusion/tsdf/marching_cubes.h"

namespace aoscan {
namespace {

/// Voxels take colour within this many voxels of the fused surface (a mesh vertex's eight voxels
/// lie within sqrt(3) voxels of it), when the frame saw a surface within the truncation along
/// their ray (at grazing angles that distance along the ray is several times the true one).
constexpr float kColourShellVoxels = 2.0f;
/// The colour of a vertex with no coloured voxel around it.
constexpr Rgb8 kUnobservedColour{128, 128, 128};

}  // namespace
namespace {

/// The model raycast is never coarser than this (pixels across): SSAO and tracking of small
/// frames (e.g. 320x240 recordings) keep their full resolution.
constexpr int kMinRaycastWidth = 320;

/// (1 - w) a + w b for two small motions, rotation vectors and translations blended apart.
Pose blend(const Pose& a, const Pose& b, double w) {
  const Eigen::AngleAxisd ra(a.rotation()), rb(b.rotation());
  const Eigen::Vector3d omega = (1.0 - w) * ra.angle() * ra.axis() + w * rb.angle() * rb.axis();
  const double angle = omega.norm();
  return Pose(angle > 0.0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                          : Eigen::Matrix3d::Identity(),
              (1.0 - w) * a.translation() + w * b.translation());
}

}  // namespace

Reconstruction::Reconstruction(const ReconstructionConfig& config)
    : config_(config), volume_(config.fusion), relocaliser_(config) {}

int Reconstruction::model_level(const Intrinsics& intrinsics) const {
  int level = std::clamp(config_.fusion.raycast_level, 0, kPyramidLevels - 1);
  while (level > 0 && intrinsics.scaled(level).width < kMinRaycastWidth) --level;
  return level;
}

FusionStep Reconstruction::process(const PreprocessedFrame& frame, const Intrinsics& intrinsics,
                                   std::shared_ptr<RaycastResult> raycast_out, bool integrate,
                                   const ColourInput* colour) {
  FusionStep step;
  if (!model_ && !lost_) {
    step.new_model = true;
    step.status = TrackingStatus::kGood;
    step.T_world_camera = T_world_last_;
  } else if (!lost_) {
    const RaycastResult& reference = first_frame_reference_ ? *first_frame_reference_ : *model_;
    // The motion prior of ICP's weakly constrained directions: the previous pose moved on by
    // the smoothed camera velocity (constant velocity in the camera frame).
    const Pose prior = has_velocity_ && config_.tracking.velocity_smoothing > 0.0
                           ? T_world_last_ * velocity_
                           : T_world_last_;
    step.icp =
        icp(frame.pyramid, reference, T_world_last_, prior, config_.tracking, icp_workspace_);
    step.status = step.icp.status;
    step.T_world_camera =
        step.icp.status == TrackingStatus::kLost ? T_world_last_ : step.icp.T_world_camera;
    if (step.status == TrackingStatus::kLost) {
      lost_ = true;
      ++losses_;
    }
  }
  const int level = model_level(intrinsics);
  const Intrinsics model_intrinsics = intrinsics.scaled(level);
  if (lost_) {
    // Nothing is fused until a pose passes the check: from the last good pose or a keyframe's.
    step.relocalisation =
        relocaliser_.relocalise(frame.pyramid, model_intrinsics, level, volume_, model_,
                                icp_workspace_);
    if (step.relocalisation.accepted) {
      lost_ = false;
      ++relocalisations_;
      step.relocalised = true;
      step.icp = step.relocalisation.icp;
      step.status = step.icp.status;
      step.T_world_camera = step.relocalisation.T_world_camera;
      first_frame_reference_.reset();
    } else {
      step.status = TrackingStatus::kLost;
      step.T_world_camera = T_world_last_;
    }
    has_velocity_ = false;
    last_is_previous_ = false;
  }
  if (step.status == TrackingStatus::kLost) {
    ++frames_lost_;
    has_velocity_ = false;
    last_is_previous_ = false;
    return step;
  }
  if (integrate || step.new_model) {
    // The colour is fused block by block inside the depth integration, while each block's
    // voxels and the depth pixels they project to are in the cache.
    std::optional<ColourIntegration> colour_frame;
    if (colour != nullptr && !colour->image.empty() && config_.fusion.colour == ColourFusion::kOn)
      colour_frame.emplace(colour_, ColourFrameInput{&frame.depth_m, intrinsics,
                                                     step.T_world_camera, &colour->image,
                                                     colour->camera,
                                                     kColourShellVoxels * volume_.voxel_size_m(),
                                                     volume_.truncation_m(),
                                                     config_.fusion.colour_max_weight});
    step.integrate = integrator_.integrate(volume_, frame.depth_m, intrinsics, step.T_world_camera,
                                           colour_frame ? &*colour_frame : nullptr);
    step.integrated = true;
    if (colour_frame) step.colour = colour_frame->finish();
  }
  if (step.new_model && volume_.block_count() == 0) {
    // Nothing fused (no valid depth): nothing to track the next frame against. The model starts
    // with the first frame that has depth.
    step.status = TrackingStatus::kLost;
    step.integrated = false;
    ++frames_lost_;
    return step;
  }
  if (!step.new_model && last_is_previous_) {
    const Pose motion = T_world_last_.inverse() * step.T_world_camera;
    velocity_ =
        has_velocity_ ? blend(velocity_, motion, config_.tracking.velocity_smoothing) : motion;
    has_velocity_ = true;
  } else {
    has_velocity_ = false;
  }
  last_is_previous_ = true;
  T_world_last_ = step.T_world_camera;
  if (step.integrated && step.status == TrackingStatus::kGood)
    relocaliser_.observe(frame.pyramid, step.T_world_camera, level);
  // The model is raycast at a pyramid level of the frame; a frame just fused at this pose is the
  // depth hint (its pyramid depth at that level has exactly the raycast's pixel grid).
  const Image<float>& hint = frame.pyramid.depth_m[level];
  const bool use_hint = step.integrated && hint.width() == model_intrinsics.width &&
                        hint.height() == model_intrinsics.height;
  raycast(volume_, model_intrinsics, step.T_world_camera, config_.fusion, *raycast_out,
          use_hint ? &hint : nullptr);
  model_ = std::move(raycast_out);
  if (step.new_model && use_hint) {
    // A model of one frame is that frame's raw depth: at 2-3 m from a Kinect v1 its raycast
    // scatters by a centimetre and more, and tracking the second frame against it slides by
    // centimetres along a room's weakly constrained directions. The frame's own filtered maps at
    // the raycast's resolution are the better reference until a second frame is fused.
    auto reference = std::make_shared<RaycastResult>();
    reference->T_world_camera = step.T_world_camera;
    reference->depth_m = hint;
    reference->maps = frame.pyramid.maps[level];
    reference->hits = count_hits(hint);
    first_frame_reference_ = std::move(reference);
  } else if (step.integrated) {
    first_frame_reference_.reset();
  }
  return step;
}

RelocalisationResult Reconstruction::relocalise(const PreprocessedFrame& frame,
                                                const Intrinsics& intrinsics) {
  const int level = model_level(intrinsics);
  return relocaliser_.relocalise(frame.pyramid, intrinsics.scaled(level), level, volume_, nullptr,
                                 icp_workspace_);
}

void Reconstruction::restore(const std::function<void(TsdfVolume&, ColourVolume&)>& fill_volume,
                             std::vector<Keyframe> keyframes) {
  reset();
  fill_volume(volume_, colour_);
  for (Keyframe& k : keyframes) relocaliser_.database().add(std::move(k));
  lost_ = true;
}

void Reconstruction::reset() {
  volume_.reset();
  integrator_.reset();
  colour_.reset();
  model_.reset();
  first_frame_reference_.reset();
  T_world_last_ = Pose();
  velocity_ = Pose();
  has_velocity_ = false;
  last_is_previous_ = false;
  lost_ = false;
  relocaliser_.database().clear();
}

void Reconstruction::colour_image(const RaycastResult& raycast, Image<Rgb8>& out) const {
  const Image<Eigen::Vector3f>& vertices = raycast.maps.vertices;
  if (colour_.block_count() == 0 || vertices.empty()) {
    out.resize(0, 0);
    return;
  }
  out.resize(vertices.width(), vertices.height());
  const Eigen::Matrix3f R = raycast.T_world_camera.rotation().cast<float>();
  const Eigen::Vector3f t = raycast.T_world_camera.translation().cast<float>();
  tbb::parallel_for(tbb::blocked_range<int>(0, vertices.height(), 8),
                    [&](const tbb::blocked_range<int>& rows) {
                      for (int y = rows.begin(); y != rows.end(); ++y) {
                        const Eigen::Vector3f* v = vertices.row(y);
                        Rgb8* dst = out.row(y);
                        for (int x = 0; x < vertices.width(); ++x) {
                          if (v[x].isZero(0.0f)) {
                            dst[x] = Rgb8{};
                          } else if (!colour_.sample(volume_, R * v[x] + t, dst[x])) {
                            dst[x] = kUnobservedColour;
                          }
                        }
                      }
                    });
}

TriangleMesh Reconstruction::extract_mesh(std::size_t* colour_unobserved) const {
  TriangleMesh mesh =
      aoscan::extract_mesh(volume_, static_cast<float>(config_.fusion.mesh_min_weight));
  std::size_t unobserved = 0;
  if (colour_.block_count() > 0) {
    mesh.colours.resize(mesh.vertices.size());
    std::atomic<std::size_t> missing{0};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.vertices.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        std::size_t n = 0;
                        for (std::size_t i = range.begin(); i != range.end(); ++i)
                          if (!colour_.sample(volume_, mesh.vertices[i], mesh.colours[i])) {
                            mesh.colours[i] = kUnobservedColour;
                            ++n;
                          }
                        missing += n;
                      });
    unobserved = missing.load();
  }
  if (colour_unobserved != nullptr) *colour_unobserved = unobserved;
  return mesh;
}

}  // namespace aoscan
