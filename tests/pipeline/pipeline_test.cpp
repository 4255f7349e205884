// Tests for src/pipeline/pipeline.cpp: dataflow, live drops (capture edge, in front of the slow
// stage), shutdown, errors.
#include "pipeline/pipeline.h"

#include <atomic>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "fake_source.h"
#include "pipeline/processing.h"

namespace aoscan {
namespace {

using testing::FakeSource;
using namespace std::chrono_literals;

/// A stage that records the sequence numbers it sees, optionally sleeping per frame.
struct Recorder {
  std::mutex mutex;
  std::vector<std::uint64_t> seen;
  StageDef stage(std::string name, std::chrono::microseconds delay = 0us) {
    return {std::move(name), [this, delay](FrameWork& f) {
              if (delay.count() > 0) std::this_thread::sleep_for(delay);
              std::lock_guard<std::mutex> lock(mutex);
              seen.push_back(f.raw.sequence);
              return Status::ok();
            }};
  }
};

TEST(Pipeline, ReplayDeliversEveryFrameOnceInOrder) {
  FakeSource source(300);
  Recorder a, b, c;
  // Uneven stage speeds make the queues fill and empty.
  const std::vector<StageDef> stages = {a.stage("a"), b.stage("b", 200us), c.stage("c", 50us)};
  PipelineOptions options;
  options.queue_capacity = 2;
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(source, stages, options, stop);
  EXPECT_TRUE(r.status.is_ok()) << r.status.message();
  EXPECT_EQ(r.counters.frames_read, 300u);
  EXPECT_EQ(r.counters.frames_processed, 300u);
  EXPECT_EQ(r.counters.frames_dropped, 0u);
  for (Recorder* rec : {&a, &b, &c}) {
    ASSERT_EQ(rec->seen.size(), 300u);
    for (std::size_t i = 0; i < rec->seen.size(); ++i) EXPECT_EQ(rec->seen[i], i);
  }
  ASSERT_EQ(r.stages.size(), 4u);
  EXPECT_EQ(r.stages[0].name(), "capture");
  EXPECT_EQ(r.stages[2].count(), 300u);
  EXPECT_GT(r.wall_s, 0.0);
}

TEST(Pipeline, MaxFramesStopsEarly) {
  FakeSource source(100);
  Recorder rec;
  PipelineOptions options;
  options.max_frames = 10;
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(source, {rec.stage("s")}, options, stop);
  EXPECT_EQ(r.counters.frames_read, 10u);
  EXPECT_EQ(r.counters.frames_processed, 10u);
}

TEST(Pipeline, LiveSourceDropsOldestAndNeverWaits) {
  FakeSource source(60, /*live=*/true);
  Recorder rec;
  PipelineOptions options;
  options.queue_capacity = 2;
  std::atomic<bool> stop{false};
  const auto t0 = std::chrono::steady_clock::now();
  const PipelineResult r = run_pipeline(source, {rec.stage("slow", 20ms)}, options, stop);
  EXPECT_TRUE(r.status.is_ok());
  // Blocking would hold the source for about 57 x 20 ms; dropping lets it finish at once.
  EXPECT_LT(std::chrono::duration<double>(source.last_read_ - t0).count(), 0.4);
  EXPECT_GT(r.counters.frames_dropped, 0u);
  EXPECT_EQ(r.counters.frames_read, 60u);
  EXPECT_EQ(r.counters.frames_processed + r.counters.frames_dropped, 60u);
  for (std::size_t i = 1; i < rec.seen.size(); ++i) EXPECT_LT(rec.seen[i - 1], rec.seen[i]);
  EXPECT_EQ(rec.seen.back(), 59u) << "the newest frame must survive";
}

/// A live camera that delivers `frames` frames as fast as they are read, each stamped as having
/// arrived `age` before read() returns. With `hold_first`, frame 1 is delivered only once
/// first_taken() was called; wait_until_ended() waits for the end of the stream.
class BurstCamera : public Source {
 public:
  BurstCamera(std::size_t frames, std::chrono::milliseconds age, bool hold_first = false)
      : frames_(frames), age_(age), hold_first_(hold_first) {
    intrinsics_.width = 8;
    intrinsics_.height = 6;
  }
  Status read(DepthFrame& frame) override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (next_ == 1 && hold_first_) cv_.wait_for(lock, 10s, [this] { return first_taken_; });
    if (next_ >= frames_) {
      ended_ = true;
      cv_.notify_all();
      return Status::end_of_stream();
    }
    frame.depth.resize(intrinsics_.width, intrinsics_.height, 1000);
    frame.intrinsics = intrinsics_;
    frame.sequence = next_++;
    frame.arrived_at = std::chrono::steady_clock::now() - age_;
    return Status::ok();
  }
  /// The first stage has frame 0: frame 1 may come.
  void first_taken() {
    std::lock_guard<std::mutex> lock(mutex_);
    first_taken_ = true;
    cv_.notify_all();
  }
  /// Waits until read() has reported the end (every frame was handed to the capture edge).
  bool wait_until_ended() {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, 10s, [this] { return ended_; });
  }
  std::string name() const override { return "burst"; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return 1000.0; }
  bool live() const override { return true; }

 private:
  std::size_t frames_;
  std::chrono::milliseconds age_;
  bool hold_first_;
  std::size_t next_ = 0;
  Intrinsics intrinsics_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool first_taken_ = false;
  bool ended_ = false;
};

TEST(Pipeline, LiveEdgeKeepsOnlyTheNewestWaitingFrame) {
  // The first stage holds frame 0 until the camera has delivered all ten: with one waiting slot
  // at the edge, frames 1..8 are each replaced by the next one, and only frame 9 waits.
  BurstCamera camera(10, 0ms, /*hold_first=*/true);
  Recorder after;
  std::vector<std::uint64_t> first_seen;
  bool ended = false;
  const StageDef first{"first", [&](FrameWork& f) {
                         if (f.raw.sequence == 0) {
                           camera.first_taken();
                           ended = camera.wait_until_ended();
                         }
                         first_seen.push_back(f.raw.sequence);
                         return Status::ok();
                       }};
  PipelineOptions options;
  options.queue_capacity = 4;  // between stages only: the live edge holds one frame regardless
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(camera, {first, after.stage("after")}, options, stop);
  EXPECT_TRUE(r.status.is_ok()) << r.status.message();
  EXPECT_TRUE(ended);
  EXPECT_EQ(first_seen, (std::vector<std::uint64_t>{0, 9}));
  EXPECT_EQ(after.seen, (std::vector<std::uint64_t>{0, 9}));
  EXPECT_EQ(r.counters.frames_read, 10u);
  EXPECT_EQ(r.counters.frames_dropped, 8u);
  EXPECT_EQ(r.counters.frames_processed, 2u);
  EXPECT_EQ(r.capture_latency.count(), 2u) << "dropped frames have no latency";
}

TEST(Pipeline, ReplayEdgeBlocksWithTheConfiguredCapacity) {
  // The same burst from a recording: nothing is dropped, every frame reaches both stages.
  FakeSource source(10);
  Recorder first, after;
  PipelineOptions options;
  options.queue_capacity = 4;
  std::atomic<bool> stop{false};
  const PipelineResult r =
      run_pipeline(source, {first.stage("first", 2ms), after.stage("after")}, options, stop);
  EXPECT_EQ(r.counters.frames_dropped, 0u);
  EXPECT_EQ(after.seen, (std::vector<std::uint64_t>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
}

/// A live camera that delivers frame k only once the first stage has taken frame k - 1 (taken()),
/// so that nothing is ever dropped at the capture edge while the first stage keeps taking frames.
class LockstepCamera : public Source {
 public:
  explicit LockstepCamera(std::size_t frames) : frames_(frames) {
    intrinsics_.width = 8;
    intrinsics_.height = 6;
  }
  Status read(DepthFrame& frame) override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (next_ >= frames_) return Status::end_of_stream();
    // A first stage that blocks never takes the previous frame: the read gives up after 10 s.
    if (!cv_.wait_for(lock, 10s, [this] { return taken_ >= next_; }))
      return Status::device_lost("the first stage stopped taking frames");
    frame.depth.resize(intrinsics_.width, intrinsics_.height, 1000);
    frame.intrinsics = intrinsics_;
    frame.sequence = next_++;
    return Status::ok();
  }
  /// The first stage has taken a frame.
  void taken() {
    std::lock_guard<std::mutex> lock(mutex_);
    ++taken_;
    cv_.notify_all();
  }
  /// Waits until the first stage has taken every frame; false after 10 s.
  bool wait_until_all_taken() {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, 10s, [this] { return taken_ >= frames_; });
  }
  std::string name() const override { return "lockstep"; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return 1000.0; }
  bool live() const override { return true; }

 private:
  std::size_t frames_;
  std::size_t next_ = 0;
  std::size_t taken_ = 0;
  Intrinsics intrinsics_;
  std::mutex mutex_;
  std::condition_variable cv_;
};

TEST(Pipeline, LiveDropsHappenInFrontOfTheStageThatTakesTheNewest) {
  // The slow stage holds frame 0 until the first stage has taken all twelve frames. Its input
  // keeps only the newest waiting frame, so the first stage never blocks on it: every frame is
  // taken at the edge as it comes, and in front of the slow stage each frame replaces the one
  // waiting there.
  constexpr std::size_t kFrames = 12;
  LockstepCamera camera(kFrames);
  Recorder first, after;
  std::vector<std::uint64_t> slow_seen;
  bool all_taken = false;
  std::promise<void> slow_started;  // the slow stage has frame 0 before frame 1 comes
  std::future<void> slow_has_frame_0 = slow_started.get_future();
  const StageDef first_stage{"first", [&](FrameWork& f) {
                               if (f.raw.sequence == 1) slow_has_frame_0.wait_for(10s);
                               camera.taken();
                               std::lock_guard<std::mutex> lock(first.mutex);
                               first.seen.push_back(f.raw.sequence);
                               return Status::ok();
                             }};
  StageDef slow{"slow", [&](FrameWork& f) {
                  if (f.raw.sequence == 0) {
                    slow_started.set_value();
                    all_taken = camera.wait_until_all_taken();
                  }
                  slow_seen.push_back(f.raw.sequence);
                  return Status::ok();
                }};
  slow.takes_newest = true;
  PipelineOptions options;
  options.queue_capacity = 4;
  std::atomic<bool> stop{false};
  const PipelineResult r =
      run_pipeline(camera, {first_stage, slow, after.stage("after")}, options, stop);
  ASSERT_TRUE(r.status.is_ok()) << r.status.message();
  EXPECT_TRUE(all_taken) << "the first stage blocked on the slow stage";
  EXPECT_EQ(first.seen.size(), kFrames);
  // The first stage counts a frame as taken before it passes it on: the slow stage may wake while
  // frame 10 still waits in front of it, so it sees {0, 11} or {0, 10, 11}.
  ASSERT_GE(slow_seen.size(), 2u);
  EXPECT_LE(slow_seen.size(), 3u);
  EXPECT_EQ(slow_seen.front(), 0u);
  EXPECT_EQ(slow_seen.back(), kFrames - 1) << "the newest frame must survive";
  if (slow_seen.size() == 3) {
    EXPECT_EQ(slow_seen[1], kFrames - 2);
  }
  EXPECT_EQ(after.seen, slow_seen);
  const std::size_t dropped = kFrames - slow_seen.size();
  EXPECT_EQ(r.counters.frames_dropped, dropped);
  EXPECT_EQ(r.counters.frames_dropped_at, (std::vector<std::size_t>{0, dropped, 0}));
  EXPECT_EQ(r.capture_latency.count(), kFrames) << "every frame was taken at the edge";
}

TEST(Pipeline, ReplayBlocksAlsoInFrontOfTheStageThatTakesTheNewest) {
  // Replay without --realtime drops nothing anywhere: every frame reaches every stage in order.
  FakeSource source(10);
  Recorder first, slow_rec, after;
  StageDef slow = slow_rec.stage("slow", 2ms);
  slow.takes_newest = true;
  PipelineOptions options;
  options.queue_capacity = 1;
  std::atomic<bool> stop{false};
  const PipelineResult r =
      run_pipeline(source, {first.stage("first"), slow, after.stage("after")}, options, stop);
  const std::vector<std::uint64_t> all{0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
  EXPECT_EQ(r.counters.frames_dropped, 0u);
  EXPECT_EQ(r.counters.frames_dropped_at, (std::vector<std::size_t>{0, 0, 0}));
  EXPECT_EQ(slow_rec.seen, all);
  EXPECT_EQ(after.seen, all);
}

TEST(Pipeline, CaptureLatencyStartsWhenTheFrameArrived) {
  // Frames stamped 40 ms before read() returns: the latency includes those 40 ms.
  BurstCamera camera(3, 40ms);
  Recorder rec;
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(camera, {rec.stage("s", 30ms)}, PipelineOptions{}, stop);
  ASSERT_GT(r.capture_latency.count(), 0u);
  EXPECT_GE(r.capture_latency.min_ms(), 40.0);
  // ... and so does the end-to-end latency, with the 30 ms of the only stage on top.
  ASSERT_EQ(r.end_to_end_latency.count(), r.counters.frames_processed);
  EXPECT_GE(r.end_to_end_latency.min_ms(), 70.0);

  // A recording leaves arrived_at empty: the pipeline stamps the delivery, so the latency is the
  // hand-over only (well below the 1 s bound even on a loaded machine), never the clock's epoch.
  FakeSource recording(5);
  const PipelineResult replay = run_pipeline(recording, {rec.stage("s")}, PipelineOptions{}, stop);
  ASSERT_EQ(replay.capture_latency.count(), 5u);
  EXPECT_GE(replay.capture_latency.min_ms(), 0.0);
  EXPECT_LT(replay.capture_latency.max_ms(), 1000.0);
  EXPECT_GE(replay.capture_cpu_percent, 0.0);
}

TEST(Pipeline, RealtimeReplayPacesAndDrops) {
  FakeSource source(30);  // timestamps 1/30 s apart: one second of recording
  Recorder rec;
  PipelineOptions options;
  options.realtime = true;
  options.queue_capacity = 1;
  std::atomic<bool> stop{false};
  const auto t0 = std::chrono::steady_clock::now();
  const PipelineResult r = run_pipeline(source, {rec.stage("slow", 100ms)}, options, stop);
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(elapsed, 29.0 / 30.0 - 0.01) << "replay must follow the recorded timestamps";
  EXPECT_GT(r.counters.frames_dropped, 0u);
  EXPECT_EQ(r.counters.frames_processed + r.counters.frames_dropped, 30u);
}

TEST(Pipeline, StopRequestFinishesFramesInFlight) {
  FakeSource source(100000);
  source.period_ = 200us;
  Recorder a, b;
  PipelineOptions options;
  std::atomic<bool> stop{false};
  std::thread stopper([&] {
    std::this_thread::sleep_for(50ms);
    stop = true;
  });
  const PipelineResult r = run_pipeline(source, {a.stage("a"), b.stage("b", 1ms)}, options, stop);
  stopper.join();
  EXPECT_TRUE(r.status.is_ok());
  EXPECT_LT(r.counters.frames_read, 100000u);
  EXPECT_GT(r.counters.frames_read, 0u);
  EXPECT_EQ(r.counters.frames_processed, r.counters.frames_read) << "frames in flight are finished";
}

TEST(Pipeline, FirstErrorStopsTheChain) {
  FakeSource source(100000);
  Recorder after;
  std::atomic<int> calls{0};
  const StageDef failing{"failing", [&](FrameWork& f) {
                           ++calls;
                           if (f.raw.sequence == 10) return Status::internal("boom at 10");
                           if (f.raw.sequence > 10) return Status::internal("later error");
                           return Status::ok();
                         }};
  PipelineOptions options;
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(source, {failing, after.stage("after")}, options, stop);
  EXPECT_EQ(r.status.code(), Status::Code::kInternal);
  EXPECT_EQ(r.status.message(), "boom at 10");
  EXPECT_EQ(r.counters.frames_processed, 10u);
  EXPECT_LT(r.counters.frames_read, 100u) << "the source must stop soon after the error";
  EXPECT_EQ(calls.load(), 11);
}

TEST(Pipeline, ExceptionsInStagesBecomeStatuses) {
  FakeSource source(5);
  const StageDef throwing{"throwing",
                          [](FrameWork&) -> Status { throw std::runtime_error("unexpected"); }};
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(source, {throwing}, {}, stop);
  EXPECT_EQ(r.status.code(), Status::Code::kInternal);
  EXPECT_NE(r.status.message().find("unexpected"), std::string::npos);
}

TEST(Pipeline, CorruptFramesAreCountedSkipsUnlessStrict) {
  FakeSource source(20);
  source.corrupt_ = {3, 7};
  Recorder rec;
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(source, {rec.stage("s")}, {}, stop);
  EXPECT_TRUE(r.status.is_ok());
  EXPECT_EQ(r.counters.frames_corrupt, 2u);
  EXPECT_EQ(r.counters.frames_processed, 18u);

  FakeSource strict_source(20);
  strict_source.corrupt_ = {3};
  Recorder rec2;
  PipelineOptions strict;
  strict.strict = true;
  const PipelineResult s = run_pipeline(strict_source, {rec2.stage("s")}, strict, stop);
  EXPECT_EQ(s.status.code(), Status::Code::kBadInput);
  EXPECT_EQ(s.status.exit_code(), ExitCode::kBadInput);
  EXPECT_EQ(s.counters.frames_processed, 3u);
}

TEST(Pipeline, DeviceLossEndsTheRunWithExitFour) {
  FakeSource source(50, /*live=*/true);
  source.fail_at_ = 20;
  Recorder rec;
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(source, {rec.stage("s")}, {}, stop);
  EXPECT_EQ(r.status.exit_code(), ExitCode::kDevice);
  EXPECT_EQ(r.counters.frames_read, 20u);
  EXPECT_EQ(r.counters.frames_processed + r.counters.frames_dropped, 20u)
      << "frames read before the loss are still processed (or dropped at the live edge)";
  EXPECT_GT(r.counters.frames_processed, 0u);
}

TEST(Pipeline, RepeatedRunsDoNotHangOrGrow) {
  for (int run = 0; run < 50; ++run) {
    FakeSource source(40);
    Recorder a, b;
    std::atomic<bool> stop{run % 2 == 1};  // half the runs are stopped before they start
    const PipelineResult r =
        run_pipeline(source, {a.stage("a"), b.stage("b")}, PipelineOptions{}, stop);
    EXPECT_TRUE(r.status.is_ok());
    EXPECT_EQ(r.counters.frames_processed, run % 2 == 1 ? 0u : 40u);
  }
}

}  // namespace
}  // namespace aoscan
