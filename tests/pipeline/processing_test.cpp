// Tests for pipeline/processing: the mvao stage's weights of a still camera's repeated views.
#include "pipeline/processing.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "pipeline/config.h"
#include "support/synth_frames.h"

namespace aoscan {
namespace {

/// Runs the chain's stages on one thread over `frames` copies of the corner's frame 0 (a camera
/// that does not move; each copy numbered on, so the SSAO's 2 x 2 stride pattern turns) and
/// returns the grid's summed weight after each frame.
std::vector<double> weight_after_each_frame(double decay, int frames,
                                            std::uint64_t* integrated = nullptr) {
  Config config;
  config.ao.still_view_decay = decay;
  Processing processing(config);
  const std::vector<StageDef> stages = processing.stages();
  std::vector<double> totals;
  for (int i = 0; i < frames; ++i) {
    FrameWork work;
    work.raw = test::corner_frame(0);
    work.raw.sequence = static_cast<std::uint64_t>(i);
    work.raw.timestamp_s = i / 30.0;
    for (const StageDef& stage : stages)
      EXPECT_TRUE(stage.process(work).is_ok()) << stage.name << " frame " << i;
    double total = 0.0;
    processing.grid().for_each_cell(
        [&](const CellIndex&, const MvaoCell& cell) { total += cell.weight_sum; });
    totals.push_back(total);
  }
  if (integrated) *integrated = processing.grid().frames_integrated();
  return totals;
}

TEST(Processing, AStillCamerasRepeatedViewsWeighDecayToTheKInTheGrid) {
  constexpr int kFrames = 5;
  const std::vector<double> full = weight_after_each_frame(1.0, kFrames);
  const std::vector<double> half = weight_after_each_frame(0.5, kFrames);
  ASSERT_GT(full[0], 0.0);
  double expected = 0.0, factor = 1.0;
  for (int i = 0; i < kFrames; ++i) {
    const double frame_weight = full[i] - (i > 0 ? full[i - 1] : 0.0);
    expected += factor * frame_weight;
    EXPECT_NEAR(half[i], expected, 1e-4 * full[i]) << "frame " << i;
    factor *= 0.5;
  }
  EXPECT_LT(half.back(), 0.6 * full.back());
  // Decay 0: only the first view of the still period is integrated.
  std::uint64_t integrated = 0;
  const std::vector<double> none = weight_after_each_frame(0.0, 3, &integrated);
  EXPECT_EQ(integrated, 1u);
  EXPECT_DOUBLE_EQ(none.back(), full[0]);
}

}  // namespace
}  // namespace aoscan
