/// @file processing.cpp
/// @brief The processing stages and the outputs they leave.
#include "pipeline/processing.h"

#include <algorithm>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "ao/mesh_ao.h"
#include "ao/ssao.h"
#include "core/log.h"
#include "fusion/preprocess/bilateral.h"
#include "fusion/preprocess/pyramid.h"
#include "io/gltf.h"
#include "io/ply.h"
#include "pipeline/pipeline_impl.h"
#include "pipeline/view_products.h"
#include "pipeline/volume_export.h"

namespace aoscan {
namespace {

constexpr double kBytesPerMb = 1024.0 * 1024.0;

/// What an `s` command left on a pooled frame must not reach the frame read into it next.
void recycle_frame(FrameWork& frame) {
  frame.export_mesh.reset();
  frame.export_trajectory.reset();
}

}  // namespace

template PipelineResult run_chain<FrameWork>(Source&, const std::vector<StageDef>&,
                                             const PipelineOptions&, const std::atomic<bool>&,
                                             const std::function<void(FrameWork&)>&);

PipelineResult run_pipeline(Source& source, const std::vector<StageDef>& stages,
                            const PipelineOptions& options,
                            const std::atomic<bool>& stop_requested) {
  return run_chain<FrameWork>(source, stages, options, stop_requested, recycle_frame);
}

nlohmann::json MeshStats::to_json() const {
  return {{"vertices", vertices},
          {"faces", faces},
          {"ao_unobserved_vertices", ao_unobserved_vertices},
          {"coloured", coloured},
          {"colour_unobserved_vertices", colour_unobserved_vertices}};
}

nlohmann::json GridStats::to_json() const {
  return {{"cells", cells},
          {"bricks", bricks},
          {"memory_mb", memory_mb},
          {"points_out_of_range", points_out_of_range}};
}

nlohmann::json TsdfStats::to_json() const {
  return {{"blocks", blocks},
          {"memory_mb", memory_mb},
          {"capacity_reached", capacity_reached},
          {"colour_blocks", colour_blocks},
          {"colour_memory_mb", colour_memory_mb}};
}

nlohmann::json VolumeStats::to_json() const {
  return {{"written", written},
          {"bricks", bricks},
          {"active_voxels", active_voxels},
          {"bytes", bytes},
          {"export_s", export_s}};
}

nlohmann::json ProcessingStats::to_json() const {
  return {{"frames_tracking_lost", frames_tracking_lost},
          {"tracking_losses", tracking_losses},
          {"relocalisations", relocalisations},
          {"keyframes", keyframes},
          {"ao_frames_skipped_live", ao_frames_skipped_live},
          {"model_resets", model_resets},
          {"outputs_written_on_request", outputs_written_on_request},
          {"frames_without_depth", frames_without_depth},
          {"frames_with_colour", frames_with_colour},
          {"frames_colour_skipped", frames_colour_skipped}};
}

Processing::Processing(const Config& config, std::string out_dir, MeshWriteOptions mesh_options)
    : config_(config),
      out_dir_(std::move(out_dir)),
      mesh_options_(mesh_options),
      reconstruction_(config),
      ao_shedder_(config.ao.live_max_interval),
      grid_(config.ao),
      still_view_(config.ao) {}

std::vector<StageDef> Processing::stages() {
  return {
      {"preprocess", [this](FrameWork& frame) { return preprocess(frame); }},
      {"filter", [this](FrameWork& frame) { return filter(frame); }},
      // Live, tracking alone can fall behind the camera: frames are dropped in front of it.
      {"track", [this](FrameWork& frame) { return track(frame); }, /*takes_newest=*/true},
      {"ssao", [this](FrameWork& frame) { return ssao(frame); }},
      {"mvao", [this](FrameWork& frame) { return mvao(frame); }},
  };
}

Status Processing::preprocess(FrameWork& frame) const {
  preprocess_depth(frame.raw, config_.preprocess, frame.pre.depth_m, &frame.pre.tracking_m);
  const Image<float>& depth = frame.pre.depth_m;
  if (std::none_of(depth.data(), depth.data() + depth.size(), [](float d) { return d > 0.0f; }))
    ++frames_without_depth_;
  if (!frame.raw.colour.empty()) ++frames_with_colour_;
  if (!frame.raw.colour_error.empty() && frames_colour_skipped_++ == 0)
    spdlog::warn("{}: colour skipped, the depth is used (further colour skips are counted in "
                 "stats.json, frames_colour_skipped)",
                 frame.raw.colour_error);
  return Status::ok();
}

Status Processing::filter(FrameWork& frame) const {
  bilateral_filter(frame.pre.tracking_depth(), config_.preprocess, frame.pre.filtered_m);
  build_pyramid(frame.pre.filtered_m, frame.raw.intrinsics, config_.preprocess, frame.pre.pyramid);
  return Status::ok();
}

Status Processing::track(FrameWork& frame) {
  frame.model_reset = reset_requested_.exchange(false);
  if (frame.model_reset) {
    reconstruction_.reset();
    trajectory_.clear();  // the world frame starts over with this frame
    ++model_resets_;
    spdlog::info("model reset at frame {}", frame.raw.sequence);
  }
  frame.integration_paused = paused_.load();
  std::shared_ptr<RaycastResult> raycast = raycasts_.acquire();
  if (frame.raw.colour_camera && !frame.raw.colour.empty() &&
      colour_frame(frame.raw.sequence, config_.fusion.colour_every)) {
    const ColourInput colour{frame.raw.colour, *frame.raw.colour_camera};
    frame.fusion = reconstruction_.process(frame.pre, frame.raw.intrinsics, raycast,
                                           !frame.integration_paused, &colour);
  } else {
    frame.fusion =
        reconstruction_.process(frame.pre, frame.raw.intrinsics, raycast, !frame.integration_paused);
  }
  const IcpResult& icp = frame.fusion.icp;
  spdlog::debug(
      "frame {}: tracking {}, inliers {:.2f}, residual {:.1f} mm, moved {:.1f} mm {:.2f} deg",
      frame.raw.sequence, to_string(frame.fusion.status), icp.inlier_ratio,
      icp.rms_residual_m * 1e3, icp.translation_m * 1e3, icp.rotation_deg);
  const bool was_lost = lost_;
  lost_ = reconstruction_.lost();
  if (lost_ && !was_lost) {
    lost_frames_before_ = frames_tracking_lost_;
    spdlog::warn("frame {}: tracking lost; move back to a scanned area", frame.raw.sequence);
  }
  if (frame.fusion.relocalised)
    spdlog::info("frame {}: relocalised {} after {} lost frames",
                 frame.raw.sequence,
                 frame.fusion.relocalisation.candidate_keyframe < 0
                     ? std::string("from the last good pose")
                     : "from keyframe " +
                           std::to_string(frame.fusion.relocalisation.candidate_keyframe),
                 frames_tracking_lost_ - lost_frames_before_);
  // A view consumer wants this frame (a window that caught up, or snapshots): its colour image
  // is made here, by the colour volume's writer, from the raycast just made. Nothing is computed
  // without a consumer.
  frame.view_candidate =
      view_products_.load() &&
      frame.raw.sequence % static_cast<std::uint64_t>(view_products_every_.load()) == 0 &&
      (!view_demand_ || view_demand_(view_products_built_.load()));
  if (frame.view_candidate && view_colour_.load() && frame.fusion.status != TrackingStatus::kLost)
    reconstruction_.colour_image(*raycast, frame.model_colour);
  else
    frame.model_colour.resize(0, 0);
  if (frame.fusion.status == TrackingStatus::kLost) {
    ++frames_tracking_lost_;
    frame.raycast.reset();
  } else {
    frame.raycast = std::move(raycast);
    trajectory_.push_back({frame.raw.timestamp_s, frame.fusion.T_world_camera});
  }
  if (write_requested_.exchange(false)) {  // `s`: this thread is the TSDF's writer
    frame.export_mesh = std::make_shared<TriangleMesh>(reconstruction_.extract_mesh());
    frame.export_trajectory = std::make_shared<const std::vector<StampedPose>>(trajectory_);
  }
  return Status::ok();
}

Status Processing::ssao(FrameWork& frame) {
  // Not tracked (no pose to place this view's AO), or skipped to keep up with a live camera.
  if (!frame.raycast || !ao_shedder_.take(frame.frames_dropped_before)) {
    frame.ssao.resize(0, 0);
    return Status::ok();
  }
  const PointMaps* maps = &frame.raycast->maps;
  if (config_.ao.input == AoInput::kRaw) {
    frame.raw_maps.intrinsics = frame.raw.intrinsics;
    compute_vertex_map(frame.pre.depth_m, frame.raw.intrinsics, frame.raw_maps.vertices);
    compute_normal_map(frame.raw_maps.vertices,
                       static_cast<float>(config_.preprocess.normal_max_depth_jump_m),
                       frame.raw_maps.normals);
    maps = &frame.raw_maps;
  }
  compute_ssao(*maps, config_.ao, frame.raw.sequence, frame.ssao, frame.ssao_weight,
               ssao_workspace_);
  return Status::ok();
}

Status Processing::mvao(FrameWork& frame) {
  if (frame.model_reset) {  // the old grid lies in the old model's world frame
    grid_.clear();
    still_view_.reset();
  }
  // Only the track stage's candidates (which have their colour image), and with a demand only
  // while the consumer is still caught up: it stays so from the candidate's track stage until a
  // product is built, so the first candidate after a catch-up is built and later ones are not.
  frame.view_products = frame.view_candidate && view_products_.load() &&
                        (!view_demand_ || view_demand_(view_products_built_.load()));
  if (frame.view_products) ++view_products_built_;
  Status status = Status::ok();
  // The view image reads the cells of the pixels just integrated through their slots when the
  // grid was fed the raycast (ao.input=raycast), the image's own maps.
  bool have_slots = false;
  // A still camera's repeated view weighs less (1 unless ao.still_view_decay < 1; 0: not at all).
  const float view_weight =
      frame.ssao.empty() ? 0.0f : still_view_.next(frame.fusion.T_world_camera);
  if (view_weight > 0.0f) {
    const bool raw = config_.ao.input == AoInput::kRaw;
    const PointMaps& maps = raw ? frame.raw_maps : frame.raycast->maps;
    have_slots = frame.view_products && !raw && config_.ao.view_read == AoViewRead::kCells;
    status = grid_.integrate(frame.ssao, frame.ssao_weight, maps, frame.fusion.T_world_camera,
                             have_slots ? &view_slots_ : nullptr, view_weight);
  }
  if (frame.view_products && frame.raycast)
    mvao_image(grid_, config_.ao.view_read, frame.raycast->maps, frame.fusion.T_world_camera,
               frame.mvao, have_slots && status.is_ok() ? &view_slots_ : nullptr);
  else
    frame.mvao.resize(0, 0);
  if (frame.export_mesh) write_requested_outputs(frame);
  return status;
}

void Processing::write_requested_outputs(FrameWork& frame) {
  const std::filesystem::path dir(out_dir_);
  try {
    apply_grid_ao(grid_, config_.ao.mesh_cell_factor, *frame.export_mesh);
    write_ply((dir / "mesh.ply").string(), *frame.export_mesh, mesh_options_);
    write_glb((dir / "mesh.glb").string(), *frame.export_mesh, mesh_options_);
    write_trajectory((dir / "trajectory.txt").string(), *frame.export_trajectory);
    ++outputs_written_;
    spdlog::info("outputs written at frame {}: {} vertices, {} poses", frame.raw.sequence,
                 frame.export_mesh->vertices.size(), frame.export_trajectory->size());
  } catch (const std::exception& e) {  // the run goes on; the final export will try again
    spdlog::warn("writing the outputs now failed: {}", e.what());
  }
  frame.export_mesh.reset();
  frame.export_trajectory.reset();
}

ProcessingStats Processing::stats() const {
  return {frames_tracking_lost_,
          reconstruction_.losses(),
          reconstruction_.relocalisations(),
          reconstruction_.relocaliser().database().keyframes().size(),
          ao_shedder_.skipped(),
          model_resets_.load(),
          outputs_written_.load(),
          frames_without_depth_.load(),
          frames_with_colour_.load(),
          frames_colour_skipped_.load()};
}

GridStats Processing::grid_stats() const {
  return {grid_.cell_count(), grid_.brick_count(),
          static_cast<double>(grid_.memory_bytes()) / kBytesPerMb, grid_.points_out_of_range()};
}

TsdfStats Processing::tsdf_stats() const {
  // The integrator's per-block bookkeeping is part of what the volume costs.
  const TsdfVolume& volume = reconstruction_.volume();
  const std::size_t bytes = volume.memory_bytes() + reconstruction_.integrator().memory_bytes();
  const ColourVolume& colour = reconstruction_.colour();
  return {static_cast<std::size_t>(volume.block_count()), static_cast<double>(bytes) / kBytesPerMb,
          volume.capacity_reached(), colour.block_count(),
          static_cast<double>(colour.memory_bytes()) / kBytesPerMb};
}

void Processing::write_trajectory_file(const std::string& path) const {
  write_trajectory(path, trajectory_);
}

Processing::ExportResult Processing::final_mesh() const {
  std::size_t colour_unobserved = 0;
  auto mesh = std::make_shared<TriangleMesh>(reconstruction_.extract_mesh(&colour_unobserved));
  const std::size_t unobserved = apply_grid_ao(grid_, config_.ao.mesh_cell_factor, *mesh);
  return {{mesh->vertices.size(), mesh->faces.size(), unobserved, !mesh->colours.empty(),
           colour_unobserved},
          mesh};
}

VolumeStats Processing::write_volume(const std::string& path) const {
  const VdbWriteStats written =
      aoscan::write_volume(path, reconstruction_.volume(), &config_.fusion,
                           &reconstruction_.colour());
  return {true, written.bricks, written.active_voxels, written.file_bytes, 0.0};
}

}  // namespace aoscan
