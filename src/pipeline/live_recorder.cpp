/// @file live_recorder.cpp
/// @brief Camera thread → BoundedQueue (drop-oldest, counted) → record_source() on the caller.
#include "pipeline/live_recorder.h"

#include <memory>
#include <thread>

#include "capture/read_status.h"
#include "core/log.h"
#include "pipeline/bounded_queue.h"
#include "pipeline/frame_pool.h"

namespace aoscan {
namespace {

using FramePtr = std::shared_ptr<DepthFrame>;

/// What the camera thread leaves behind for the writer.
struct CameraOutcome {
  Status status;                   ///< ok (ended or stopped) or the error that ended the capture
  std::size_t frames_corrupt = 0;  ///< corrupt frames reported by the camera
};

/// The writer's view of the queue: a Source whose frames are the queued ones.
class QueueSource : public Source {
 public:
  QueueSource(Source& camera, BoundedQueue<FramePtr>& queue, const CameraOutcome& outcome)
      : camera_(camera), queue_(queue), outcome_(outcome) {}

  Status read(DepthFrame& frame) override {
    std::optional<FramePtr> item = queue_.pop();
    if (!item) {
      // The camera thread stored its outcome before closing the queue.
      if (outcome_.status.is_ok()) return Status::end_of_stream();
      return outcome_.status;
    }
    std::swap(frame, **item);  // the pooled object takes the old buffers back: no allocation
    return Status::ok();
  }
  std::string name() const override { return camera_.name(); }
  const Intrinsics& intrinsics() const override { return camera_.intrinsics(); }
  double depth_scale() const override { return camera_.depth_scale(); }
  const TriangleMesh* scene_mesh() const override { return camera_.scene_mesh(); }

 private:
  Source& camera_;
  BoundedQueue<FramePtr>& queue_;
  const CameraOutcome& outcome_;
};

void camera_loop(Source& source, std::optional<std::size_t> max_frames,
                 const std::atomic<bool>& stop_requested, ObjectPool<DepthFrame>& pool,
                 BoundedQueue<FramePtr>& queue, CameraOutcome& outcome) {
  std::size_t frames_read = 0;
  source.watch_stop(&stop_requested);
  while (!stop_requested.load()) {
    if (max_frames && frames_read >= *max_frames) break;
    FramePtr frame = pool.acquire();
    const ReadStep step =
        handle_read_status(source.read(*frame), {/*strict=*/false, "skipping corrupt frame: "},
                           outcome.frames_corrupt, outcome.status);
    if (step == ReadStep::kStop) break;
    if (step == ReadStep::kSkip) continue;
    ++frames_read;
    if (!queue.push(std::move(frame))) break;  // the writer gave up
  }
  queue.close();
}

}  // namespace

RecordStats record_live_source(Source& source, const std::string& dir,
                               std::optional<std::size_t> max_frames,
                               const std::atomic<bool>& stop_requested,
                               const LiveRecordOptions& options) {
  ObjectPool<DepthFrame> pool;  // outlives the queue and every frame in it
  BoundedQueue<FramePtr> queue(options.queue_capacity, OverflowPolicy::kDropOldest);
  CameraOutcome outcome;
  QueueSource queued(source, queue, outcome);

  std::thread camera(camera_loop, std::ref(source), max_frames, std::cref(stop_requested),
                     std::ref(pool), std::ref(queue), std::ref(outcome));
  RecordStats stats;
  try {
    stats = record_source(queued, dir, max_frames, nullptr);
  } catch (...) {
    queue.close_and_clear();  // the camera thread's next push fails and it stops
    camera.join();
    if (queue.dropped() > 0)
      spdlog::warn("{} frames of {} were dropped: the disk could not keep up", queue.dropped(),
                   source.name());
    throw;
  }
  queue.close_and_clear();  // max_frames written: nothing more is wanted
  camera.join();
  stats.frames_dropped = queue.dropped();
  stats.frames_corrupt += outcome.frames_corrupt;
  return stats;
}

}  // namespace aoscan
