/// @file processing.h
/// @brief aoscan's processing stages and the state each one owns (one writer per structure):
/// preprocess (metres, border outliers) → filter (bilateral, pyramid, vertex and normal maps) →
/// track+integrate(+raycast) → ssao → mvao. Used by replay/scan sessions and by the
/// benchmark.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ao/mvao_grid.h"
#include "ao/ssao.h"
#include "core/mesh.h"
#include "fusion/reconstruction.h"
#include "io/tum.h"
#include "io/vdb.h"
#include "pipeline/ao_load_shedder.h"
#include "pipeline/config.h"
#include "pipeline/frame_pool.h"
#include "pipeline/pipeline.h"

namespace aoscan {

/// Owns the reconstruction and what the stages collect; hands out the stage functions.
class Processing {
 public:
  /// `out_dir`: where the `s` command (request_write_outputs) writes mesh.ply and trajectory.txt.
  explicit Processing(const Config& config, std::string out_dir = "aoscan-out");

  /// The stages in chain order. They capture `this`: keep this object alive while they run.
  std::vector<StageDef> stages();

  /// Asks the track stage to start a new model before its next frame: empty TSDF, identity pose,
  /// empty trajectory; the mvao stage clears the grid when that frame reaches it (thread-safe).
  void request_reset() { reset_requested_.store(true); }
  /// Pauses / resumes integration: frames are still tracked and counted (thread-safe).
  void set_paused(bool paused) { paused_.store(paused); }
  /// Asks for mesh.ply and trajectory.txt in out_dir now (thread-safe): the track stage extracts
  /// the surface after its next frame, the mvao stage gives it AO and writes both files.
  void request_write_outputs() { write_requested_.store(true); }
  /// While enabled the mvao stage fills FrameWork::mvao for the view consumers, for every
  /// `every`-th frame of the source (thread-safe).
  void set_view_products(bool enabled, int every = 1) {
    view_products_every_.store(every < 1 ? 1 : every);
    view_products_.store(enabled);
  }
  /// With a demand set (before the chain starts), the mvao stage builds the view products of a
  /// frame only when `ready(products built so far)` says the consumer has caught up: the window
  /// is shown as often as it can draw, and no product is made that it would never show.
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

  /// Writes trajectory.txt and mesh.ply into `out_dir` (read after the chain has stopped).
  /// Returns the mesh statistics for stats.json.
  struct ExportStats {
    std::size_t mesh_vertices = 0;
    std::size_t mesh_faces = 0;
    std::size_t ao_unobserved_vertices = 0;  ///< vertices that took the nearest observed cell's AO
    std::shared_ptr<const TriangleMesh> mesh;  ///< the mesh written, with its AO
  };
  ExportStats write_outputs(const std::string& out_dir) const;
  /// Writes the TSDF as `out_dir`/volume.vdb (see pipeline/volume_export.h; read after the chain
  /// has stopped). Throws Error (exit code 1) naming the file when it cannot be written.
  VdbWriteStats write_volume(const std::string& out_dir) const;

 private:
  Status preprocess(FrameWork& frame) const;
  Status filter(FrameWork& frame) const;
  Status track(FrameWork& frame);
  Status ssao(FrameWork& frame);
  Status mvao(FrameWork& frame);
  void write_requested_outputs(FrameWork& frame);

  Config config_;
  std::string out_dir_;
  /// Raycasts in flight (tracking reference + downstream); declared before reconstruction_,
  /// which holds one of them, so that it outlives every pointer it handed out.
  ObjectPool<RaycastResult> raycasts_;
  Reconstruction reconstruction_;    ///< written by the track stage only
  AoLoadShedder ao_shedder_;         ///< used by the ssao stage only
  SsaoWorkspace ssao_workspace_;     ///< used by the ssao stage only
  MvaoGrid grid_;                    ///< written by the mvao stage only
  Image<std::uint32_t> view_slots_;  ///< the grid slots of the frame's pixels, for mvao_image()
  std::vector<StampedPose> trajectory_;
  std::size_t frames_tracking_lost_ = 0;
  std::atomic<bool> reset_requested_{false};
  std::atomic<bool> paused_{false};
  std::atomic<bool> write_requested_{false};
  std::atomic<bool> view_products_{false};
  std::atomic<int> view_products_every_{1};
  std::function<bool(std::uint64_t)> view_demand_;
  std::uint64_t view_products_built_ = 0;  ///< by the mvao stage
  std::atomic<std::size_t> model_resets_{0};
  std::atomic<std::size_t> outputs_written_{0};
};

}  // namespace aoscan
