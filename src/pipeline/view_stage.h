/// @file view_stage.h
/// @brief The "view" stage at the end of the chain: turns each fused frame into an immutable
/// ViewFrame for the live window (through a latest-wins mailbox) and the `--snapshot` PNGs, on
/// its own stage thread so that neither ever runs on the track/ssao/mvao threads.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/status.h"
#include "pipeline/frame_pool.h"
#include "pipeline/mailbox.h"
#include "pipeline/processing.h"
#include "pipeline/view_products.h"
#include "render/snapshot.h"
#include "render/view_frame.h"

namespace aoscan {

struct ViewStageOptions {
  /// Names for FrameWork::stage_ms in the HUD, capture first (e.g. capture, preprocess, ...).
  std::vector<std::string> stage_names;
  bool publish = false;                      ///< put each ViewFrame in the mailbox (a window)
  std::optional<SnapshotOptions> snapshots;  ///< write PNGs of every N-th frame
  SurfaceCloudOptions surface;               ///< the orbit view's point cloud
  int surface_every = 5;                     ///< frames between two published copies of the cloud
  /// A window or snapshots consume the frames (they show every view): set_views() is ignored.
  bool publish_all_views = true;
  /// Told whether the views consumed need the fused colour (set_views()); may be empty.
  std::function<void(bool)> on_colour_needed;
};

/// Owns the ViewFrame pool, the mailbox, the snapshot writer and the orbit cloud. process() and
/// finish() run on one thread at a time (the stage's, then the owner's after the chain stopped);
/// mailbox(), set_publish() and the counters are thread-safe.
class ViewStage {
 public:
  /// Creates the snapshot folder: throws usage_error naming it when it cannot be created.
  explicit ViewStage(ViewStageOptions options);

  /// The stage function: builds the frame's ViewFrame (buffers reused from the pool), publishes
  /// it and offers it to the snapshot writer. Never waits for a mailbox reader. A failed snapshot
  /// is logged once and ends the snapshots, not the run.
  Status process(FrameWork& frame);

  /// After the chain has stopped: writes the snapshot set of the last frame again with `surface`
  /// (the final mesh with AO, may be null) as the orbit view's surface. No-op without snapshots
  /// or frames.
  void finish(std::shared_ptr<const TriangleMesh> surface);

  /// The newest ViewFrame (the live view's feed).
  Mailbox<std::shared_ptr<const ViewFrame>>& mailbox() { return mailbox_; }
  /// The newest ViewFrame for the window, remembered as shown (thread-safe); null before the first.
  std::shared_ptr<const ViewFrame> take_latest();
  /// True when every frame with view products built so far (`built`, counted by their producer)
  /// has arrived here and the window has taken the newest published one (thread-safe): the
  /// producer's cue to build the next.
  bool caught_up(std::uint64_t built) const {
    return products_arrived_.load() == built && taken_version_.load() >= mailbox_.version();
  }
  /// Stops (false) or resumes building frames for the window, e.g. when none could be opened.
  void set_publish(bool publish) { publish_.store(publish); }
  /// The views a consumer that shows only some of them (the service's viewers) watches now: the
  /// fused colour is made only for the colour views, the orbit cloud's mesh only for the orbit
  /// and splats views. Ignored while a window or snapshots (which show every view) are consumers
  /// (thread-safe).
  void set_views(const std::vector<View>& views);

  std::size_t frames_seen() const { return frames_seen_.load(); }
  std::size_t snapshot_files() const { return snapshot_files_.load(); }

 private:
  bool active() const { return publish_.load() || snapshots_.has_value(); }
  void fill(const FrameWork& frame, ViewFrame& view);
  double recent_fps(std::chrono::steady_clock::time_point now);

  ViewStageOptions options_;
  ObjectPool<ViewFrame> pool_;  ///< declared first: outlives every frame in the mailbox
  Mailbox<std::shared_ptr<const ViewFrame>> mailbox_;
  std::optional<SnapshotWriter> snapshots_;
  std::shared_ptr<const ViewFrame> last_;
  SurfaceCloud cloud_;
  std::shared_ptr<const TriangleMesh> surface_;
  std::size_t frames_since_surface_ = 0;
  std::deque<std::chrono::steady_clock::time_point> done_times_;
  std::vector<double> smoothed_ms_;
  std::atomic<bool> publish_{false};
  std::atomic<bool> surface_wanted_{true};  ///< the orbit cloud's mesh is published
  std::atomic<std::size_t> frames_seen_{0};
  std::atomic<std::uint64_t> products_arrived_{0};  ///< frames with view products seen
  std::atomic<std::uint64_t> taken_version_{0};     ///< mailbox version take_latest() returned
  std::atomic<std::size_t> snapshot_files_{0};
};

}  // namespace aoscan
