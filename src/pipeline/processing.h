/// @file processing.h
/// @brief aoscan's frame (FrameWork), its processing stages and the state each one owns (one
/// writer per structure): preprocess (metres, border outliers) → filter (bilateral, pyramid,
/// vertex and normal maps) → track+integrate(+raycast) → ssao → mvao; the chain over FrameWork
/// and the stats the stages leave. Used by replay/scan sessions and by the benchmark.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "ao/mvao_grid.h"
#include "ao/ssao.h"
#include "ao/still_view.h"
#include "core/depth_frame.h"
#include "core/image.h"
#include "core/mesh.h"
#include "fusion/preprocess/preprocess.h"
#include "fusion/reconstruction.h"
#include "io/mesh_write.h"
#include "io/tum.h"
#include "io/vdb.h"
#include "pipeline/ao_load_shedder.h"
#include "pipeline/config.h"
#include "pipeline/frame_pool.h"
#include "pipeline/pipeline.h"

namespace aoscan {

/// Everything one frame accumulates on its way through the chain; recycled between frames.
struct FrameWork {
  DepthFrame raw;         ///< as read from the source
  PreprocessedFrame pre;  ///< metres, outliers removed, filtered, tracking pyramid
  FusionStep fusion;      ///< tracking status and pose
  std::shared_ptr<const RaycastResult>
      raycast;               ///< the model seen from this frame's pose, when tracked
  PointMaps raw_maps;        ///< camera-frame maps of pre.depth_m (only with ao.input=raw)
  Image<float> ssao;         ///< screen-space AO of this view, 1 = open (empty when not tracked)
  Image<float> ssao_weight;  ///< per-pixel view weight w_d * w_n

  /// Milliseconds this frame spent in each step: [0] = capture (read), [i] = the i-th StageDef,
  /// filled as it passes (for the HUD; StageStats keep the run's statistics).
  std::vector<double> stage_ms;
  std::size_t frames_dropped_before = 0;  ///< live drops counted when this frame was queued
  bool integration_paused = false;  ///< the track stage tracked this frame without integrating it
  bool model_reset = false;         ///< the track stage started a new model with this frame
  /// Only while a view consumer exists: AO from the MVAO grid at each raycast pixel's world point,
  /// in [0, 1], NaN = unobserved cell or no surface (filled by the mvao stage after integrating).
  Image<float> mvao;
  /// The track stage found a view consumer wanting this frame (set_view_products(), and with a
  /// demand the consumer caught up): it filled model_colour; the mvao stage decides
  /// view_products among such frames only.
  bool view_candidate = false;
  /// Only for view candidates: the fused colour of the surface at each raycast pixel
  /// (Reconstruction::colour_image(), computed by the track stage, the colour's writer, right
  /// after the raycast); empty when the run has no fused colour or the frame was not tracked.
  Image<Rgb8> model_colour;
  /// The mvao stage built this frame's view products (mvao): the view stage shows only such frames.
  bool view_products = false;
  /// `s` (write outputs now): the surface extracted by the track stage after this frame (world
  /// frame, no AO yet) and the trajectory so far; the mvao stage adds the AO and writes both.
  std::shared_ptr<TriangleMesh> export_mesh;
  std::shared_ptr<const std::vector<StampedPose>> export_trajectory;
};

/// A stage of aoscan's chain.
using StageDef = ChainStage<FrameWork>;

/// The chain (pipeline/pipeline.h) over FrameWork: a recycled frame drops the outputs an `s`
/// command left on it.
PipelineResult run_pipeline(Source& source, const std::vector<StageDef>& stages,
                            const PipelineOptions& options,
                            const std::atomic<bool>& stop_requested);

/// The final mesh (stats.json "mesh").
struct MeshStats {
  std::size_t vertices = 0;
  std::size_t faces = 0;
  std::size_t ao_unobserved_vertices = 0;  ///< vertices that took the nearest observed cell's AO
  bool coloured = false;                   ///< the vertices have the fused colour
  std::size_t colour_unobserved_vertices = 0;  ///< ... but no coloured voxel near these (grey)
  nlohmann::json to_json() const;
};

/// The MVAO grid at the end of the run (stats.json "mvao_grid").
struct GridStats {
  std::size_t cells = 0;
  std::size_t bricks = 0;  ///< bricks of 4^3 cells
  double memory_mb = 0.0;
  std::uint64_t points_out_of_range = 0;
  nlohmann::json to_json() const;
};

/// The TSDF at the end of the run (stats.json "tsdf").
struct TsdfStats {
  std::size_t blocks = 0;
  double memory_mb = 0.0;
  bool capacity_reached = false;
  std::size_t colour_blocks = 0;  ///< blocks with fused colour (ColourVolume)
  double colour_memory_mb = 0.0;  ///< what the colour holds, beside memory_mb
  nlohmann::json to_json() const;
};

/// volume.vdb, when --save-volume asked for it (stats.json "volume").
struct VolumeStats {
  bool written = false;
  std::size_t bricks = 0;         ///< 8^3 bricks (OpenVDB leaves) with observed voxels
  std::size_t active_voxels = 0;  ///< observed voxels
  std::uintmax_t bytes = 0;       ///< the file's size
  double export_s = 0.0;          ///< time to write it
  nlohmann::json to_json() const;
};

/// What the stages counted (stats.json top-level keys).
struct ProcessingStats {
  std::size_t frames_tracking_lost = 0;  ///< frames spent lost (not fused)
  std::size_t tracking_losses = 0;       ///< times tracking was lost
  std::size_t relocalisations = 0;       ///< times a lost take was relocalised
  std::size_t keyframes = 0;             ///< in the relocalisation database at the end
  std::size_t ao_frames_skipped_live = 0;  ///< tracked frames without SSAO under live load
  std::size_t model_resets = 0;            ///< `r` commands carried out
  std::size_t outputs_written_on_request = 0;  ///< `s` commands carried out
  /// Frames with no depth left after preprocessing: every raw value 0 (invalid) or outside
  /// preprocess.min_depth_m .. max_depth_m.
  std::size_t frames_without_depth = 0;
  std::size_t frames_with_colour = 0;     ///< frames that came with a colour image
  /// Frames whose colour was skipped (missing, corrupt, another size, no colour near in time):
  /// their depth was used all the same.
  std::size_t frames_colour_skipped = 0;
  nlohmann::json to_json() const;
};

struct LoadedSession;

/// Owns the reconstruction and what the stages collect; hands out the stage functions.
class Processing {
 public:
  /// `out_dir`: where the `s` command (request_write_outputs) writes mesh.ply, mesh.glb and
  /// trajectory.txt, the meshes as `mesh_options` say (--bake-ao), as the final export does.
  explicit Processing(const Config& config, std::string out_dir = "aoscan-out",
                      MeshWriteOptions mesh_options = {});

  /// Continues a saved session (before the chain starts): its TSDF, MVAO grid, keyframes and
  /// trajectory; tracking starts lost, so the first frames are relocalised against its
  /// keyframes. Throws input_error naming the session's file when its grid does not fit.
  /// (saved_session.cpp)
  void restore(const LoadedSession& session);

  /// The stages in chain order. They capture `this`: keep this object alive while they run.
  std::vector<StageDef> stages();

  /// Asks the track stage to start a new model before its next frame: empty TSDF, identity pose,
  /// empty trajectory; the mvao stage clears the grid when that frame reaches it (thread-safe).
  void request_reset() { reset_requested_.store(true); }
  /// Pauses / resumes integration: frames are still tracked and counted (thread-safe).
  void set_paused(bool paused) { paused_.store(paused); }
  /// Asks for mesh.ply, mesh.glb and trajectory.txt in out_dir now (thread-safe): the track
  /// stage extracts the surface after its next frame, the mvao stage gives it AO and writes them.
  void request_write_outputs() { write_requested_.store(true); }
  /// While enabled the track stage fills FrameWork::model_colour and the mvao stage
  /// FrameWork::mvao for the view consumers, for every `every`-th frame of the source
  /// (thread-safe). Disabled (the default, a headless run without snapshots) neither is computed.
  void set_view_products(bool enabled, int every = 1) {
    view_products_every_.store(every < 1 ? 1 : every);
    view_products_.store(enabled);
  }
  /// Whether the view products include the fused colour image (FrameWork::model_colour): only
  /// the colour views show it (thread-safe; on by default).
  void set_view_colour(bool enabled) { view_colour_.store(enabled); }
  /// With a demand set (before the chain starts), the view products of a frame are built only
  /// when `ready(products built so far)` says the consumer has caught up: the window is shown as
  /// often as it can draw, and no product is made that it would never show. It is asked by the
  /// track stage (a candidate gets its colour image) and again by the mvao stage (which builds
  /// the products of a candidate): it must be thread-safe.
  void set_view_demand(std::function<bool(std::uint64_t)> ready) {
    view_demand_ = std::move(ready);
  }

  /// Models started by request_reset() so far, and on-demand writes done (thread-safe).
  std::size_t model_resets() const { return model_resets_.load(); }
  std::size_t outputs_written_on_request() const { return outputs_written_.load(); }

  /// Poses of the tracked frames, in order (read after the chain has stopped).
  const std::vector<StampedPose>& trajectory() const { return trajectory_; }
  std::size_t frames_tracking_lost() const { return frames_tracking_lost_; }
  const Reconstruction& reconstruction() const { return reconstruction_; }
  const MvaoGrid& grid() const { return grid_; }
  /// Tracked frames whose SSAO the ssao stage skipped under live load (read after the chain has
  /// stopped; see AoLoadShedder).
  std::size_t ao_frames_skipped() const { return ao_shedder_.skipped(); }

  /// The counts of the stages, the grid and the TSDF (read after the chain has stopped).
  ProcessingStats stats() const;
  GridStats grid_stats() const;
  TsdfStats tsdf_stats() const;

  /// The run's outputs, read after the chain has stopped. Each write throws Error (exit code 1)
  /// naming the file when it cannot be written.
  /// Writes the trajectory (trajectory.txt) to `path`.
  void write_trajectory_file(const std::string& path) const;
  /// The fused surface with the grid's AO per vertex, and its stats.
  struct ExportResult {
    MeshStats stats;
    std::shared_ptr<const TriangleMesh> mesh;
  };
  ExportResult final_mesh() const;
  /// Writes the TSDF (volume.vdb, see pipeline/volume_export.h) to `path`; the result's export_s
  /// is left for the caller, who times the write.
  VolumeStats write_volume(const std::string& path) const;

 private:
  Status preprocess(FrameWork& frame) const;
  Status filter(FrameWork& frame) const;
  Status track(FrameWork& frame);
  Status ssao(FrameWork& frame);
  Status mvao(FrameWork& frame);
  void write_requested_outputs(FrameWork& frame);

  Config config_;
  std::string out_dir_;
  MeshWriteOptions mesh_options_;
  /// Raycasts in flight (tracking reference + downstream); declared before reconstruction_,
  /// which holds one of them, so that it outlives every pointer it handed out.
  ObjectPool<RaycastResult> raycasts_;
  Reconstruction reconstruction_;    ///< written by the track stage only
  AoLoadShedder ao_shedder_;         ///< used by the ssao stage only
  SsaoWorkspace ssao_workspace_;     ///< used by the ssao stage only
  MvaoGrid grid_;                    ///< written by the mvao stage only
  StillViewWeight still_view_;       ///< used by the mvao stage only
  Image<std::uint32_t> view_slots_;  ///< the grid slots of the frame's pixels, for mvao_image()
  std::vector<StampedPose> trajectory_;
  std::size_t frames_tracking_lost_ = 0;
  bool lost_ = false;           ///< tracking was lost after the last frame (track stage)
  std::size_t lost_frames_before_ = 0;  ///< frames_tracking_lost_ when it was last lost (log)
  std::atomic<bool> reset_requested_{false};
  std::atomic<bool> paused_{false};
  std::atomic<bool> write_requested_{false};
  std::atomic<bool> view_products_{false};
  std::atomic<bool> view_colour_{true};
  std::atomic<int> view_products_every_{1};
  std::function<bool(std::uint64_t)> view_demand_;
  std::atomic<std::uint64_t> view_products_built_{0};  ///< by the mvao stage (read by track)
  std::atomic<std::size_t> model_resets_{0};
  std::atomic<std::size_t> outputs_written_{0};
  mutable std::atomic<std::size_t> frames_without_depth_{0};  ///< counted by the preprocess stage
  mutable std::atomic<std::size_t> frames_with_colour_{0};     ///< counted by the preprocess stage
  mutable std::atomic<std::size_t> frames_colour_skipped_{0};  ///< counted by the preprocess stage
};

}  // namespace aoscan
