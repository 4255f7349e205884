// Tests for src/fusion/relocaliser.cpp and the lost state of src/fusion/reconstruction.cpp: takes
// of the synthetic corner that black out or jump for two seconds while the camera moves a metre,
// a camera carried into another scene, and the depth comparison of the relocalisation check.
#include "fusion/relocaliser.h"

#include <cstdio>

#include <gtest/gtest.h>

#include "sim/synth_camera.h"
#include "sim/synth_scene.h"
#include "support/relocalisation_takes.h"

namespace aoscan {
namespace {

/// The tests' takes run at 15 fps: the same path and gap in half the frames (aoscan-reloc-bench
/// measures them at 30 fps).
constexpr int kStep = 2;

test::TakeOptions take() {
  test::TakeOptions options;
  options.frame_step = kStep;
  return options;
}

test::TakeOptions gap_take(bool cut) {
  test::TakeOptions options = take();
  options.gap_begin = test::kTakeGapBegin;
  options.gap_end = test::kTakeGapEnd;
  options.cut_gap = cut;
  return options;
}

/// The uninterrupted take: the reference of the interrupted ones (computed once).
const test::TakeResult& whole_take() {
  static const test::TakeResult result = test::run_take(take());
  return result;
}

void print(const char* name, const test::TakeResult& r) {
  std::printf("%s: ATE %.2f mm, losses %zu, relocalisations %zu (first at frame %d), lost %zu, "
              "keyframes %zu, worst relocalised %.1f mm %.2f deg\n",
              name, 1e3 * r.ate_m, r.losses, r.relocalisations, r.first_relocalised,
              r.frames_lost, r.keyframes, 1e3 * r.worst_relocalised_m, r.worst_relocalised_deg);
}

/// Each take is a few hundred frames rendered, preprocessed and fused: under the sanitizers (5-20
/// times slower) the jump, the other scenes and the depth comparison cover the relocalisation's
/// code; the accuracy comparisons with the uninterrupted take run in the Release suite.
#if defined(AOSCAN_SANITIZED)
#define SKIP_ACCURACY_UNDER_SANITIZERS() \
  GTEST_SKIP() << "an accuracy comparison of whole takes; too slow under the sanitizers"
constexpr bool kCompareWithWholeTake = false;
#else
#define SKIP_ACCURACY_UNDER_SANITIZERS() static_cast<void>(0)
constexpr bool kCompareWithWholeTake = true;
#endif

TEST(Relocalisation, TheUninterruptedTakeIsNeverLost) {
  SKIP_ACCURACY_UNDER_SANITIZERS();
  const test::TakeResult& whole = whole_take();
  print("uninterrupted", whole);
  EXPECT_EQ(whole.losses, 0u);
  EXPECT_EQ(whole.frames_lost, 0u);
  EXPECT_LT(whole.ate_m, 0.01);
  EXPECT_GT(whole.keyframes, 3u);
}

/// Checks an interrupted take against the uninterrupted one: lost once at the gap, nothing fused
/// until relocalised within 10 frames (of the take) of the gap's end, the ATE within 1 mm.
void expect_recovered(const test::TakeResult& r) {
  EXPECT_EQ(r.losses, 1u);
  EXPECT_EQ(r.relocalisations, 1u);
  ASSERT_GE(r.first_relocalised, test::kTakeGapEnd);
  EXPECT_LT(r.first_relocalised, test::kTakeGapEnd + 10 * kStep);
  for (const test::TakeFrame& f : r.frames) {
    if (f.index >= test::kTakeGapBegin && f.index < r.first_relocalised) {
      EXPECT_EQ(f.status, TrackingStatus::kLost) << "frame " << f.index;
      EXPECT_FALSE(f.integrated) << "frame " << f.index;
    } else {
      EXPECT_NE(f.status, TrackingStatus::kLost) << "frame " << f.index;
    }
  }
  EXPECT_LT(r.worst_relocalised_m, 0.02);
  EXPECT_LT(r.worst_relocalised_deg, 1.0);
  if (kCompareWithWholeTake) {
    EXPECT_NEAR(r.ate_m, whole_take().ate_m, 0.001);
  }
}

TEST(Relocalisation, ATakeThatBlacksOutForTwoSecondsIsRelocalised) {
  SKIP_ACCURACY_UNDER_SANITIZERS();
  const test::TakeResult r = test::run_take(gap_take(false));
  print("blackout", r);
  expect_recovered(r);
}

TEST(Relocalisation, ATakeThatJumpsAMetreIsRelocalised) {
  const test::TakeResult r = test::run_take(gap_take(true));
  print("jump", r);
  expect_recovered(r);
}

TEST(Relocalisation, WithoutFernsAJumpedTakeStaysLost) {
  SKIP_ACCURACY_UNDER_SANITIZERS();
  test::TakeOptions options = gap_take(true);
  options.config.relocalisation.ferns = 0;
  const test::TakeResult r = test::run_take(options);
  print("no ferns", r);
  // From the last good pose, a metre away, ICP cannot pass the check: the rest stays lost.
  EXPECT_EQ(r.losses, 1u);
  EXPECT_EQ(r.relocalisations, 0u);
  EXPECT_EQ(r.keyframes, 0u);
  for (const test::TakeFrame& f : r.frames)
    if (f.index >= test::kTakeGapEnd) {
      EXPECT_EQ(f.status, TrackingStatus::kLost) << "frame " << f.index;
      EXPECT_FALSE(f.integrated) << "frame " << f.index;
    }
}

TEST(Relocalisation, ACameraCarriedIntoAnotherSceneIsNeverRelocalised) {
  // Map the corner from the first 90 frames of the take, then show frames of the room and of the
  // plane scene: however similar their codes, no pose may pass the check.
  const test::TakeOptions options = take();
  Reconstruction rec(options.config);
  const Intrinsics k = synth_intrinsics(options.width, options.height);
  const AnalyticScene corner = AnalyticScene::make("corner");
  PreprocessedFrame frame;
  for (int i = 0; i < 90; i += kStep) {
    test::take_frame(corner, test::sweep_take_pose(i / 30.0), i, false, options, frame);
    ASSERT_NE(rec.process(frame, k, std::make_shared<RaycastResult>()).status,
              TrackingStatus::kLost);
  }
  for (const char* name : {"room", "plane"}) {
    const AnalyticScene other = AnalyticScene::make(name);
    for (int i = 0; i < 60; i += 6) {
      const Pose T = synth_camera_pose(name, SynthTrajectory::kOrbit, 1, i / 30.0);
      test::take_frame(other, T, 1000 + i, false, options, frame);
      const FusionStep step = rec.process(frame, k, std::make_shared<RaycastResult>());
      EXPECT_EQ(step.status, TrackingStatus::kLost) << name << " frame " << i;
      EXPECT_FALSE(step.integrated);
      EXPECT_TRUE(step.T_world_camera.finite());
    }
  }
  EXPECT_EQ(rec.relocalisations(), 0u);
  EXPECT_TRUE(rec.lost());
  // Back in the corner near frame 60: relocalised.
  test::take_frame(corner, test::sweep_take_pose(60 / 30.0), 60, false, options, frame);
  const FusionStep back = rec.process(frame, k, std::make_shared<RaycastResult>());
  EXPECT_TRUE(back.relocalised);
  EXPECT_EQ(rec.relocalisations(), 1u);
}

TEST(Relocalisation, DepthComparisonCountsAgreementSeeThroughAndOverlap) {
  Image<float> frame(4, 1, 0.0f), model(4, 1, 0.0f);
  // Pixel 0: agrees; 1: the frame sees 20 cm beyond the model; 2: an object in front of the
  // model; 3: frame depth where the model has none.
  frame(0, 0) = 1.00f;
  model(0, 0) = 1.01f;
  frame(1, 0) = 1.20f;
  model(1, 0) = 1.00f;
  frame(2, 0) = 0.80f;
  model(2, 0) = 1.00f;
  frame(3, 0) = 1.00f;
  const DepthAgreement a = compare_depth(frame, model, 0.03, 1.0);
  EXPECT_EQ(a.frame_pixels, 4);
  EXPECT_EQ(a.both, 3);
  EXPECT_EQ(a.agree, 1);
  EXPECT_EQ(a.see_through, 1);
  EXPECT_DOUBLE_EQ(a.overlap(), 0.75);
  // Beyond the reference depth the tolerance grows with depth squared: 3 cm at 1 m, 12 cm at 2 m.
  Image<float> far_frame(1, 1, 2.10f), far_model(1, 1, 2.0f);
  EXPECT_EQ(compare_depth(far_frame, far_model, 0.03, 1.0).agree, 1);
  EXPECT_EQ(compare_depth(far_frame, far_model, 0.03, 0.0).see_through, 1);
  // Images of different sizes compare nothing.
  EXPECT_EQ(compare_depth(frame, far_model, 0.03, 1.0).frame_pixels, 0);
}

}  // namespace
}  // namespace aoscan
