// Tests for src/pipeline/pipeline.cpp: dataflow, drops at the capture edge, shutdown, errors.
#include "pipeline/pipeline.h"

#include <atomic>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "fake_source.h"

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
  EXPECT_EQ(r.stages[2].samples_ms().size(), 300u);
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

TEST(Pipeline, RealtimeReplayPacesAndDrops) {
  FakeSource source(30);  // timestamps 1/30 s apart: one second of recording
  Recorder rec;
  PipelineOptions options;
  options.realtime = true;
  options.queue_capacity = 1;
  std::atomic<bool> stop{false};
  const auto t0 = std::chrono::steady_clock::now();
  const PipelineResult r = run_pipeline(source, {rec.stage("slow", 100ms)}, options, stop);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
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
  const StageDef throwing{"throwing", [](FrameWork&) -> Status {
                            throw std::runtime_error("unexpected");
                          }};
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
