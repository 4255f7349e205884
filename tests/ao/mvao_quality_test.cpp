// The multi-scan MVAO of `aoscan scans` against the ray-traced Eq. 1 reference on small synthetic
// scan sets (the harness of the aoscan-mvao-quality benchmark, support/mvao_quality.h): the
// issue's quality target on three laser scans of the room, and what holds on three depth-camera
// frames of the corner, with 2 mm of noise and with a Kinect's; on the first two, the border
// weight w_b smoothing the coverage borders.
#include <cstdio>

#include <gtest/gtest.h>

#include "support/mvao_quality.h"

namespace aoscan {
namespace {

void print(const test::QualityRow& r) {
  std::printf(
      "%s (%dx%d): %lld evaluated points, %lld border pairs; r: SSAO %.4f, MVAO %.4f (3x3 %.4f, "
      "without w_b %.4f); step error at coverage borders: w_b %.5f, without %.5f\n",
      r.set.c_str(), r.map_width, r.map_height, r.evaluated, r.border_pairs, r.ssao_r, r.mvao_r,
      r.mvao_3x3_r, r.mvao_no_wb_r, r.wb_step_error, r.no_wb_step_error);
}

/// The quality of three 320 x 240 depth-camera frames of the corner with `noise`.
test::QualityRow three_corner_frames(test::QualityNoise noise) {
  test::QualitySet set;
  set.scene = "corner";
  set.camera = test::QualityCamera::kPinhole;
  set.noise = noise;
  set.scans = 3;
  set.pinhole_width = 320;
  set.pinhole_height = 240;
  return test::measure_mvao_quality(set, test::QualityOptions{});
}

TEST(MvaoQuality, ThreeLaserScansOfTheRoomClearTheRTargetAndSmoothTheirSeams) {
#if defined(AOSCAN_SANITIZED)
  GTEST_SKIP() << "an accuracy measurement on three large scans; too slow under the sanitizers, "
                  "which run the same harness on the depth-camera set below";
#endif
  // 640 x 320 maps, 2 mm range noise, normals estimated from the points, the default AoConfig.
  // Measured: SSAO 0.970, MVAO 0.978 (3x3 0.960, without w_b 0.977); step error 0.0199 with w_b,
  // 0.0284 without, over 824 border pairs. Without alchemy's area factor: SSAO 0.967, MVAO 0.975
  // (3x3 0.956, without w_b 0.974), step error 0.0173 and 0.0228. Without it and with the reference
  // at the surface points nearest to the noisy points instead of the points' ray hits, as in the
  // older figures that follow: SSAO 0.964, MVAO 0.971 (3x3 0.950, without w_b 0.970). With the SSAO
  // smoothed by 1 px whatever the pixel's size (before it was limited to r_s / 10 in metres: these
  // pixels span 2-3 cm), SSAO 0.942 and MVAO 0.957; before the windows and sample disks near the
  // poles spanned as many metres along a row as along a column, SSAO 0.874 and MVAO 0.954: the
  // scans' own errors, which the other scans averaged out, made most of the MVAO's lead over the
  // SSAO (BENCHMARKS.md).
  test::QualitySet set;
  set.scene = "room";
  set.camera = test::QualityCamera::kEquirect;
  set.scans = 3;
  set.equirect_height = 320;
  const test::QualityRow r = test::measure_mvao_quality(set, test::QualityOptions{});
  print(r);
  EXPECT_GT(r.evaluated, 50000);
  EXPECT_GT(r.border_pairs, 500);
  EXPECT_GE(r.ssao_r, 0.94);
  EXPECT_GE(r.mvao_r, 0.955);
  EXPECT_GE(r.mvao_r, r.ssao_r + 0.005);
  EXPECT_GE(r.mvao_3x3_r, 0.90);
  // w_b makes the MVAO's step across coverage borders closer to the reference's, and raises r
  // now that the range noise makes no edges (kBorderNoiseMedians; before it w_b cost 0.004 here).
  EXPECT_LT(r.wb_step_error, 0.9 * r.no_wb_step_error);
  EXPECT_GT(r.mvao_r, r.mvao_no_wb_r);
}

TEST(MvaoQuality, ThreeDepthCameraFramesOfTheCornerGainLessButSmoothTheirSeams) {
  // 320 x 240 frames (fx = 262.5) with 2 mm range noise through the depth preprocessing. Each
  // frame's own SSAO is already close to the MVAO's ceiling here (with the scene's exact normals
  // the SSAO reaches 0.91, the MVAO 0.94 on the benchmark's 640 x 480 frames), so the MVAO gains
  // 0.034, not the 0.05 of the target; it does clear r 0.90. The frustum edges are coverage
  // borders on open surfaces, the seams w_b is for.
  const test::QualityRow r = three_corner_frames(test::QualityNoise::kLaser);
  print(r);
  // Measured: SSAO 0.894, MVAO 0.932 (3x3 0.931, without w_b 0.917); step error 0.0073 with
  // w_b, 0.0183 without, over 1278 border pairs. Without alchemy's area factor SSAO 0.896, MVAO
  // 0.931, step error 0.0058 and 0.0121; without it and with the reference at the nearest surface
  // points: SSAO 0.894, MVAO 0.928, step error 0.0060 (0.0050 while the depth camera's dropouts
  // still counted as borders).
  EXPECT_GT(r.evaluated, 20000);
  EXPECT_GT(r.border_pairs, 1000);
  EXPECT_GE(r.mvao_r, 0.90);
  EXPECT_GE(r.mvao_r, r.ssao_r + 0.015);
  EXPECT_LT(r.wb_step_error, 0.6 * r.no_wb_step_error);
  EXPECT_GE(r.mvao_r, r.mvao_no_wb_r);
}

TEST(MvaoQuality, ThreeKinectFramesOfTheCornerReadTheirPointsOnTheirPlanes) {
  // The same frames with the Kinect v1 noise model (about 2 mm at 1 m, 6 mm at 2 m, disparity
  // steps): the scans' own noise widens their normal fits and the SSAO reads the points on the
  // fitted planes (compute_scan_normals()), the scans find each other's points within that
  // noise (corresponding_pixel()), its dropouts are no coverage borders (border_distance()), and
  // its wider fits near a crease take the windows beside the point. Measured: SSAO 0.739, MVAO
  // 0.766, 65.7 % of the points seen by two scans or more (the 640 x 480 frames of the benchmark:
  // 0.883, 0.913, 78.8 %); without alchemy's area factor 0.713, 0.745 (benchmark 0.886, 0.911).
  // Without it and with the reference at the nearest surface points, as in all the figures that
  // follow: 0.710, 0.741 (benchmark 0.864, 0.888); with centred windows alone SSAO
  // 0.675, MVAO 0.707; with the dropouts as borders too, MVAO 0.694; with the 2 t test alone 0.690
  // and 57.6 %; with the 2 cm fits alone, as before the noise model, SSAO 0.405, MVAO 0.424.
  const test::QualityRow r = three_corner_frames(test::QualityNoise::kKinect);
  print(r);
  const double covered_twice = static_cast<double>(r.covered_twice) / r.points;
  std::printf("seen by two scans or more: %.1f %% of the points\n", 100.0 * covered_twice);
  EXPECT_GT(covered_twice, 0.62);
  EXPECT_GT(r.evaluated, 10000);
  EXPECT_GE(r.ssao_r, 0.62);
  EXPECT_GE(r.mvao_r, 0.64);
  EXPECT_GE(r.mvao_r, r.ssao_r);
}

}  // namespace
}  // namespace aoscan
