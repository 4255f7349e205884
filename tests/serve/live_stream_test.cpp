// The live stream driven by hand (its own thread is slowed to never tick): one encoding per view
// and frame, the newest frame for each viewer, a viewer that never reads skips frames without
// holding anyone up, the figures of the newest frame.
#include "serve/live_stream.h"

#include <chrono>

#include <gtest/gtest.h>

#include "io/colour_image.h"
#include "pipeline/view_stage.h"

namespace aoscan {
namespace {

using namespace std::chrono_literals;

LiveStreamOptions hand_driven() {
  LiveStreamOptions options;
  options.max_fps = 1e-4;  // the thread's first tick is hours away: the test calls pump()
  options.status_hz = 1e-4;
  return options;
}

ViewStageOptions publishing() {
  ViewStageOptions options;
  options.stage_names = {"capture", "view"};
  options.publish = true;
  return options;
}

/// Gives the view stage frame `sequence` (with view products, as the mvao stage marks them).
void feed(ViewStage& stage, std::uint64_t sequence) {
  FrameWork frame;
  frame.raw.sequence = sequence;
  frame.raw.intrinsics.width = 64;
  frame.raw.intrinsics.height = 48;
  frame.view_products = true;
  frame.stage_ms = {5.0, 7.0};  // capture, then a stage named "view" (publishing())
  ASSERT_TRUE(stage.process(frame).is_ok());
}

TEST(LiveStream, EachViewerGetsTheNewestFrameAndASlowOneOnlySkips) {
  ViewStage stage(publishing());
  LiveStream stream(hand_driven());
  stream.attach(&stage);
  const auto fast = stream.add_viewer(View::kShaded);
  const auto slow = stream.add_viewer(View::kShaded);
  const auto other = stream.add_viewer(View::kDepth);
  ASSERT_TRUE(fast && slow && other);
  EXPECT_EQ(stream.viewers(), 3u);
  for (std::uint64_t k = 0; k < 5; ++k) {
    feed(stage, k);
    stream.pump();
    const auto frame = fast->next(0ms);
    ASSERT_NE(frame, nullptr) << k;
    EXPECT_EQ(frame->sequence, k);
    EXPECT_EQ(frame->view, View::kShaded);
    Image<Rgb8> image;
    ASSERT_TRUE(decode_colour_image(frame->jpeg.data(), frame->jpeg.size(), image, "frame").is_ok());
    EXPECT_EQ(image.width(), 64);
    EXPECT_EQ(image.height(), 48);
    EXPECT_EQ(fast->next(0ms), nullptr);  // nothing newer
  }
  // The same frame is not sent twice.
  stream.pump();
  EXPECT_EQ(fast->next(0ms), nullptr);
  // One encoding per view and frame, whatever the number of viewers.
  EXPECT_EQ(stream.frames_encoded(), 10u);
  const auto newest = slow->next(0ms);
  ASSERT_NE(newest, nullptr);
  EXPECT_EQ(newest->sequence, 4u);
  EXPECT_EQ(slow->frames_skipped(), 4u);
  EXPECT_EQ(fast->frames_skipped(), 0u);
  EXPECT_EQ(other->next(0ms)->view, View::kDepth);

  const LiveFigures figures = stream.figures();
  EXPECT_TRUE(figures.valid);
  EXPECT_EQ(figures.sequence, 4u);
  EXPECT_EQ(figures.frames_processed, 5u);
  EXPECT_EQ(figures.to_json()["sequence"], 4);
  // The stages in the chain's order, not sorted by name.
  const nlohmann::json stages = figures.to_json()["stage_ms"];
  ASSERT_EQ(stages.size(), 2u);
  EXPECT_EQ(stages[0]["stage"], "capture");
  EXPECT_EQ(stages[0]["ms"], 5.0);
  EXPECT_EQ(stages[1]["stage"], "view");

  // A viewer that changes its view gets the current frame again in it.
  fast->set_view(View::kNormals);
  stream.refresh();
  stream.pump();
  const auto again = fast->next(0ms);
  ASSERT_NE(again, nullptr);
  EXPECT_EQ(again->sequence, 4u);
  EXPECT_EQ(again->view, View::kNormals);

  stream.remove_viewer(slow);
  EXPECT_TRUE(slow->closed());
  EXPECT_EQ(slow->next(1000ms), nullptr);  // closed: returns at once
  EXPECT_EQ(stream.viewers(), 2u);
  stream.attach(nullptr);
  EXPECT_FALSE(stream.figures().valid);
  feed(stage, 5);
  stream.pump();  // detached: nothing taken
  EXPECT_EQ(fast->next(0ms), nullptr);
}

TEST(LiveStream, ViewersBeyondTheLimitAreRefused) {
  LiveStreamOptions options = hand_driven();
  options.max_viewers = 2;
  LiveStream stream(options);
  const auto a = stream.add_viewer(View::kShaded);
  const auto b = stream.add_viewer(View::kShaded);
  EXPECT_TRUE(a && b);
  EXPECT_EQ(stream.add_viewer(View::kShaded), nullptr);
  stream.remove_viewer(a);
  EXPECT_NE(stream.add_viewer(View::kShaded), nullptr);
}

TEST(LiveStream, ViewNames) {
  for (int i = 0; i < kViewCount; ++i) {
    const View view = static_cast<View>(i);
    EXPECT_EQ(view_named(view_name(view)), view);
  }
  EXPECT_EQ(view_named("nosuch"), std::nullopt);
}

}  // namespace
}  // namespace aoscan
