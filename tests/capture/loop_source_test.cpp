/// @file loop_source_test.cpp
/// @brief `replay --loop N`: exact frame order, timestamps, sequence numbers and counts of the
/// ping-pong loop, and the sources and pass counts it refuses.
#include "capture/loop_source.h"

#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "capture/png_depth.h"
#include "capture/synth_source.h"
#include "capture/tum_source.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;
using testing::write_text;

/// A seekable in-memory source of `timestamps.size()` frames: frame i is 2x1 pixels of value
/// 100 + i, stamped timestamps[i]; frames listed in `corrupt` read as corrupt_frame.
class FakeSource final : public Source {
 public:
  explicit FakeSource(std::vector<double> timestamps, std::vector<std::size_t> corrupt = {},
                      bool seekable = true)
      : timestamps_(std::move(timestamps)), corrupt_(std::move(corrupt)), seekable_(seekable) {
    intrinsics_.width = 2;
    intrinsics_.height = 1;
  }
  Status read(DepthFrame& frame) override {
    if (next_ >= timestamps_.size()) return Status::end_of_stream();
    const std::size_t i = next_++;
    for (std::size_t c : corrupt_)
      if (c == i) return Status::corrupt_frame("fake frame " + std::to_string(i));
    frame.depth = Image<std::uint16_t>(2, 1);
    frame.depth(0, 0) = frame.depth(1, 0) = static_cast<std::uint16_t>(100 + i);
    frame.timestamp_s = timestamps_[i];
    frame.sequence = i;
    frame.origin = "fake " + std::to_string(i);
    return Status::ok();
  }
  std::string name() const override { return "fake"; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return 1000.0; }
  std::optional<std::size_t> size() const override { return timestamps_.size(); }
  bool seekable() const override { return seekable_; }
  Status seek(std::size_t index) override {
    if (!seekable_ || index >= timestamps_.size()) return Source::seek(index);
    next_ = index;
    return Status::ok();
  }

 private:
  std::vector<double> timestamps_;
  std::vector<std::size_t> corrupt_;
  bool seekable_;
  Intrinsics intrinsics_;
  std::size_t next_ = 0;
};

/// One delivered frame: the source's frame index (from its pixels), sequence and timestamp; or
/// a corrupt-frame message.
struct Delivered {
  int index = -1;
  std::uint64_t sequence = 0;
  double timestamp_s = 0.0;
  std::string corrupt;
};

std::vector<Delivered> drain(Source& source) {
  std::vector<Delivered> out;
  DepthFrame frame;
  for (;;) {
    const Status s = source.read(frame);
    if (s.code() == Status::Code::kEndOfStream) break;
    if (s.code() == Status::Code::kCorruptFrame) {
      out.push_back({-1, 0, 0.0, s.message()});
      continue;
    }
    EXPECT_TRUE(s.is_ok()) << s.message();
    if (!s.is_ok()) break;
    out.push_back({static_cast<int>(frame.depth(0, 0)) - 100, frame.sequence, frame.timestamp_s,
                   ""});
  }
  EXPECT_EQ(source.read(frame).code(), Status::Code::kEndOfStream);  // and stays there
  return out;
}

std::vector<int> indices(const std::vector<Delivered>& d) {
  std::vector<int> out;
  for (const Delivered& x : d) out.push_back(x.index);
  return out;
}

// Four frames at 10, 10.1, 10.3, 10.6 s: span S = 0.6 s, mean step d = 0.2 s, pass p starts at
// 10 + 0.8 p.
const std::vector<double> kTimes{10.0, 10.1, 10.3, 10.6};

TEST(LoopSource, OnePassIsTheSourceUnchanged) {
  auto loop = make_loop_source(std::make_unique<FakeSource>(kTimes), 1);
  EXPECT_EQ(loop->size(), std::optional<std::size_t>(4));
  EXPECT_EQ(loop->name(), "fake");
  EXPECT_FALSE(loop->live());
  const std::vector<Delivered> d = drain(*loop);
  ASSERT_EQ(d.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(d[i].index, static_cast<int>(i));
    EXPECT_EQ(d[i].sequence, i);
    EXPECT_DOUBLE_EQ(d[i].timestamp_s, kTimes[i]);
  }
}

TEST(LoopSource, TwoPassesPlayForwardThenBackwardWithContinuingTimestamps) {
  auto loop = make_loop_source(std::make_unique<FakeSource>(kTimes), 2);
  EXPECT_EQ(loop->size(), std::optional<std::size_t>(8));
  const std::vector<Delivered> d = drain(*loop);
  EXPECT_EQ(indices(d), (std::vector<int>{0, 1, 2, 3, 3, 2, 1, 0}));
  // Backward: 10.8 + (10.6 - t): the recorded spacing mirrored (0.3, 0.2, 0.1).
  const std::vector<double> expected{10.0, 10.1, 10.3, 10.6, 10.8, 11.1, 11.3, 11.4};
  ASSERT_EQ(d.size(), expected.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_EQ(d[i].sequence, i);
    EXPECT_NEAR(d[i].timestamp_s, expected[i], 1e-12) << "position " << i;
  }
}

TEST(LoopSource, ThreePassesTurnTwiceAndCountNFrames) {
  auto loop = make_loop_source(std::make_unique<FakeSource>(kTimes), 3);
  EXPECT_EQ(loop->size(), std::optional<std::size_t>(12));
  const std::vector<Delivered> d = drain(*loop);
  EXPECT_EQ(indices(d), (std::vector<int>{0, 1, 2, 3, 3, 2, 1, 0, 0, 1, 2, 3}));
  const std::vector<double> expected{10.0, 10.1, 10.3, 10.6, 10.8, 11.1,
                                     11.3, 11.4, 11.6, 11.7, 11.9, 12.2};
  ASSERT_EQ(d.size(), expected.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_EQ(d[i].sequence, i);
    EXPECT_NEAR(d[i].timestamp_s, expected[i], 1e-12) << "position " << i;
    if (i > 0) {
      EXPECT_GT(d[i].timestamp_s, d[i - 1].timestamp_s);
    }
  }
}

TEST(LoopSource, OneFrameSourceRepeatsAtThirtyHertz) {
  auto loop = make_loop_source(std::make_unique<FakeSource>(std::vector<double>{5.0}), 3);
  const std::vector<Delivered> d = drain(*loop);
  EXPECT_EQ(indices(d), (std::vector<int>{0, 0, 0}));
  ASSERT_EQ(d.size(), 3u);
  EXPECT_DOUBLE_EQ(d[0].timestamp_s, 5.0);
  EXPECT_DOUBLE_EQ(d[1].timestamp_s, 5.0 + kLoopFallbackFrameInterval);
  EXPECT_DOUBLE_EQ(d[2].timestamp_s, 5.0 + 2 * kLoopFallbackFrameInterval);
  EXPECT_EQ(d[2].sequence, 2u);
}

TEST(LoopSource, CorruptFramesKeepTheirPositionInEveryPass) {
  // Frame 1 unreadable: reported in both passes, and its positions (1 and 6) are not reused.
  auto loop = make_loop_source(std::make_unique<FakeSource>(kTimes, std::vector<std::size_t>{1}),
                               2);
  const std::vector<Delivered> d = drain(*loop);
  EXPECT_EQ(indices(d), (std::vector<int>{0, -1, 2, 3, 3, 2, -1, 0}));
  EXPECT_EQ(d[1].corrupt, "fake frame 1");
  EXPECT_EQ(d[6].corrupt, "fake frame 1");
  EXPECT_EQ(d[5].sequence, 5u);
  EXPECT_EQ(d[7].sequence, 7u);
  EXPECT_NEAR(d[7].timestamp_s, 11.4, 1e-12);
}

TEST(LoopSource, RefusesPassCountsOutsideItsRangeAndSourcesWithoutRandomAccess) {
  for (std::int64_t bad : {std::int64_t{0}, std::int64_t{-1}, kMaxLoopPasses + 1}) {
    try {
      make_loop_source(std::make_unique<FakeSource>(kTimes), bad);
      ADD_FAILURE() << "accepted --loop " << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kUsage);
      EXPECT_EQ(std::string(e.what()), "--loop " + std::to_string(bad) +
                                           ": the number of passes must be 1 to 100000");
    }
  }
  EXPECT_NO_THROW(make_loop_source(std::make_unique<FakeSource>(kTimes), kMaxLoopPasses));
  try {
    make_loop_source(std::make_unique<FakeSource>(kTimes, std::vector<std::size_t>{}, false), 2);
    ADD_FAILURE() << "accepted a source without random access";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_EQ(std::string(e.what()),
              "--loop: fake cannot be played backward (a recording folder or a synth: scene can)");
  }
}

TEST(LoopSource, RecordingFolderPlaysBackwardFrameByFrame) {
  // A TUM folder of 3 frames at t = 2 + i/10 s: frame i is a constant image of value 100 + i.
  ScratchDir scratch;
  const std::string folder = scratch.file("rec");
  std::filesystem::create_directories(folder + "/depth");
  std::string list;
  for (int i = 0; i < 3; ++i) {
    Image<std::uint16_t> image(2, 1);
    image(0, 0) = image(1, 0) = static_cast<std::uint16_t>(100 + i);
    write_depth_png(folder + "/depth/" + std::to_string(i) + ".png", image);
    char line[64];
    std::snprintf(line, sizeof line, "%.1f depth/%d.png\n", 2.0 + i / 10.0, i);
    list += line;
  }
  write_text(folder + "/depth.txt", list);
  auto loop = make_loop_source(open_tum_folder(folder), 2);
  const std::vector<Delivered> d = drain(*loop);
  EXPECT_EQ(indices(d), (std::vector<int>{0, 1, 2, 2, 1, 0}));
  const std::vector<double> expected{2.0, 2.1, 2.2, 2.3, 2.4, 2.5};
  ASSERT_EQ(d.size(), expected.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_EQ(d[i].sequence, i);
    EXPECT_NEAR(d[i].timestamp_s, expected[i], 1e-9);
  }
}

TEST(LoopSource, SynthSceneBackwardPassRepeatsTheFramesExactly) {
  const std::string spec = "synth:plane?frames=3&width=32&height=24&noise=kinect&seed=4";
  auto plain = open_synth_source(spec);
  std::vector<DepthFrame> forward(3);
  for (DepthFrame& f : forward) ASSERT_TRUE(plain->read(f).is_ok());
  auto loop = make_loop_source(open_synth_source(spec), 2);
  EXPECT_NE(loop->scene_mesh(), nullptr);
  DepthFrame frame;
  for (int position = 0; position < 6; ++position) {
    ASSERT_TRUE(loop->read(frame).is_ok());
    const int index = position < 3 ? position : 5 - position;
    EXPECT_EQ(frame.depth, forward[index].depth) << "position " << position;
    ASSERT_TRUE(frame.T_world_camera_gt.has_value());
    EXPECT_EQ(frame.T_world_camera_gt->matrix(), forward[index].T_world_camera_gt->matrix())
        << "position " << position;
    EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(position));
  }
  EXPECT_EQ(loop->read(frame).code(), Status::Code::kEndOfStream);
}

}  // namespace
}  // namespace aoscan
