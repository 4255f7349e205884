// Tests for tools/eval/image_eval: the image-space AO measures on hand-made views, depths and
// grids whose answers are known exactly.
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "image_eval.h"
#include "io/colour_image.h"

namespace aoscan::eval {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// A fresh empty folder under the system's temporary folder, removed at the end of the test.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() /
              ("aoscan_image_eval_" + name + "_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()))) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() { std::filesystem::remove_all(path_); }
  std::string str() const { return path_.string(); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

/// A pinhole camera of width x height pixels, fx = fy = f.
Intrinsics camera(int width, int height, double f, double cx, double cy) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = f;
  k.cx = cx;
  k.cy = cy;
  return k;
}

/// An empty MVAO grid of 0.5 m cells.
MvaoGrid half_metre_grid() {
  AoConfig config;
  config.grid_resolution = 8;
  config.grid_extent_m = 4.0;
  return MvaoGrid(config);
}

TEST(ImageEval, GreyPixelsShowTheirAoAndAnyOtherColourShowsNone) {
  EXPECT_EQ(shown_ao(Rgb8{0, 0, 0}), 0.0f);
  EXPECT_EQ(shown_ao(Rgb8{255, 255, 255}), 1.0f);
  EXPECT_FLOAT_EQ(shown_ao(Rgb8{51, 51, 51}), 0.2f);
  EXPECT_TRUE(std::isnan(shown_ao(Rgb8{24, 24, 32})));  // the views' background
  EXPECT_TRUE(std::isnan(shown_ao(Rgb8{10, 11, 10})));
}

TEST(ImageEval, SnapshotFramesAreThoseWithBothViewsAndTheViewsReadBack) {
  const ScratchDir dir("frames");
  Image<Rgb8> view(4, 3, Rgb8{24, 24, 32});
  view(1, 2) = Rgb8{102, 102, 102};
  for (const char* name : {"ssao_000000.png", "mvao_000000.png", "ssao_000030.png",
                           "mvao_000060.png", "ssao_000060.png", "shaded_000090.png",
                           "mvao_000090.png", "ssao_000120.png.partial", "mvao_000120.png"})
    write_colour_png(dir.file(name), view);
  EXPECT_EQ(snapshot_frames(dir.str()), (std::vector<std::uint64_t>{0, 60}));
  EXPECT_EQ(snapshot_path("d", "mvao", 60), (std::filesystem::path("d") / "mvao_000060.png").string());
  const Image<float> ao = read_shown_ao(dir.str(), "ssao", 60);
  ASSERT_EQ(ao.width(), 4);
  ASSERT_EQ(ao.height(), 3);
  EXPECT_FLOAT_EQ(ao(1, 2), 0.4f);
  EXPECT_TRUE(std::isnan(ao(0, 0)));
  EXPECT_THROW(read_shown_ao(dir.str(), "ssao", 30 + 1), Error);
  EXPECT_THROW(snapshot_frames(dir.file("missing")), Error);
}

TEST(ImageEval, BorderMaskHoldsThePixelsWithinItsWidthOfTheEdge) {
  const Image<std::uint8_t> mask = border_mask(100, 90, 40);
  std::size_t in = 0;
  for (std::size_t i = 0; i < mask.size(); ++i) in += mask.data()[i];
  EXPECT_EQ(in, 100u * 90u - 20u * 10u);  // the interior is x in [40, 60), y in [40, 50)
  EXPECT_EQ(mask(39, 45), 1);
  EXPECT_EQ(mask(40, 45), 0);
  EXPECT_EQ(mask(59, 45), 0);
  EXPECT_EQ(mask(60, 45), 1);
  EXPECT_EQ(mask(50, 39), 1);
  EXPECT_EQ(mask(50, 40), 0);
  EXPECT_EQ(mask(50, 49), 0);
  EXPECT_EQ(mask(50, 50), 1);
}

TEST(ImageEval, DiscontinuityMaskCoversFivePixelsAroundBothSidesOfAJumpAndAHole) {
  // Left half 1 m, right half 2 m: a jump between columns 29 and 30; a gentle slope (4 % per
  // pixel, below the 5 % threshold) elsewhere must not count.
  Image<float> depth(60, 40);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 60; ++x) depth(x, y) = x < 30 ? 1.0f : 2.0f;
  const Image<std::uint8_t> jump = discontinuity_mask(depth, 5);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 60; ++x) EXPECT_EQ(jump(x, y), x >= 24 && x <= 35) << x << "," << y;

  Image<float> slope(60, 40);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 60; ++x) slope(x, y) = 1.0f + 0.0004f * static_cast<float>(x * x);
  // Neighbours differ by 0.0004 (2x + 1) m, at most 0.047 m (x = 58), under 5 % of 1 m and more.
  const Image<std::uint8_t> none = discontinuity_mask(slope, 5);
  for (std::size_t i = 0; i < none.size(); ++i) EXPECT_EQ(none.data()[i], 0);

  // One pixel without a surface at (10, 20): it and its four neighbours are discontinuities; the
  // mask is every pixel within 5 px of one of them.
  Image<float> hole(60, 40, 1.5f);
  hole(10, 20) = 0.0f;
  const Image<std::uint8_t> mask = discontinuity_mask(hole, 5);
  EXPECT_EQ(mask(10, 20), 1);
  EXPECT_EQ(mask(16, 20), 1);  // 5 px from (11, 20)
  EXPECT_EQ(mask(17, 20), 0);
  EXPECT_EQ(mask(14, 24), 1);  // 3^2 + 4^2 = 25 from (11, 20)
  EXPECT_EQ(mask(15, 24), 0);  // 32 from (11, 20), 34 from (10, 21)
  EXPECT_EQ(mask(10, 26), 1);
  EXPECT_EQ(mask(10, 27), 0);
  std::size_t in = 0;
  for (std::size_t i = 0; i < mask.size(); ++i) in += mask.data()[i];
  // The 81 pixels of the disc of radius 5 around the hole, and 8 more beyond each of its four
  // sides from the discs around the neighbours.
  EXPECT_EQ(in, 81u + 4u * 8u);
}

TEST(ImageEval, RegionCorrelationIsPearsonOverEachRegionsPixels) {
  RegionCorrelation c;
  // reference, then ssao (reversed: r = -1), mvao (affine: r = 1), final (two swapped: r = 0.8).
  const double reference[4] = {0.1, 0.2, 0.3, 0.4};
  const double ssao[4] = {0.4, 0.3, 0.2, 0.1};
  const double final_ao[4] = {0.1, 0.3, 0.2, 0.4};
  const bool border[4] = {true, true, false, true};
  const bool discontinuity[4] = {false, false, true, true};
  for (int i = 0; i < 4; ++i)
    c.add({ssao[i], 2 * reference[i] + 0.1, final_ao[i]}, reference[i], border[i],
          discontinuity[i]);
  EXPECT_EQ(c.count(Region::kAll), 4u);
  EXPECT_EQ(c.count(Region::kBorder), 3u);
  EXPECT_EQ(c.count(Region::kDiscontinuity), 2u);
  EXPECT_NEAR(c.r(Region::kAll, Shown::kSsao), -1.0, 1e-12);
  EXPECT_NEAR(c.r(Region::kAll, Shown::kMvao), 1.0, 1e-12);
  EXPECT_NEAR(c.r(Region::kAll, Shown::kFinal), 0.8, 1e-12);
  // Border: reference (3, 6, 12) / 30 and final (3, 9, 12) / 30: r = 39 / 42.
  EXPECT_NEAR(c.r(Region::kBorder, Shown::kFinal), 13.0 / 14.0, 1e-12);
  EXPECT_NEAR(c.r(Region::kDiscontinuity, Shown::kSsao), -1.0, 1e-12);
  EXPECT_NEAR(c.mean(Region::kBorder, Shown::kSsao), (0.4 + 0.3 + 0.1) / 3, 1e-12);
  EXPECT_NEAR(c.mean_reference(Region::kDiscontinuity), 0.35, 1e-12);
  RegionCorrelation twice = c;
  twice.merge(c);
  EXPECT_EQ(twice.count(Region::kBorder), 6u);
  EXPECT_NEAR(twice.r(Region::kAll, Shown::kFinal), 0.8, 1e-12);
}

/// A 16 x 12 camera 1.2 m in front of the `plane` scene's wall (y = 0, facing -y), looking at it
/// square on: the camera's z is the scene's +y.
ImageEvalFrame plane_frame() {
  ImageEvalFrame f;
  f.intrinsics = camera(16, 12, 10, 7.5, 5.5);
  Eigen::Matrix3d R;  // camera x -> scene x, camera y -> scene -z, camera z -> scene y
  R << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  f.T_scene_camera = Pose(R, Eigen::Vector3d(0.3, -1.2, 1.0));
  f.T_world_camera = Pose();
  f.ssao = Image<float>(16, 12, kNaN);
  f.mvao = Image<float>(16, 12, kNaN);
  return f;
}

TEST(ImageEval, FrameReadsEachRaycastPixelAtItsBlocksFirstViewPixel) {
  const AnalyticScene scene = AnalyticScene::make("plane");
  ImageEvalFrame f = plane_frame();
  // Only the even pixels (the first of each 2 x 2 block of the half-resolution raycast) show
  // values; a reader of any other pixel would find no SSAO or MVAO.
  for (int y = 0; y < 12; y += 2)
    for (int x = 0; x < 16; x += 2) {
      f.ssao(x, y) = 0.5f;
      f.mvao(x, y) = 0.75f;
    }
  f.mvao(6, 4) = kNaN;  // raycast pixel (3, 2): an unobserved cell
  // The final grid: 0.5 m cells; the wall is at camera z = 1.2 (cells z = 2), x within
  // +-0.84 m, y within +-0.6 m. Observe every cell there but x = -2 (x < -0.5 m).
  MvaoGrid grid = half_metre_grid();
  for (int x = -1; x <= 1; ++x)
    for (int y = -2; y <= 1; ++y) ASSERT_TRUE(grid.restore_cell({x, y, 2}, {0.25f, 1.0f, 1}));
  ImageEvalOptions options;
  options.step = 1;
  options.border_px = 2;
  RegionCorrelation c;
  ImageEvalCounts counts;
  std::vector<CellSample> cells;
  evaluate_frame(scene, grid, f, options, c, counts, &cells);
  EXPECT_EQ(cells.size(), counts.compared);
  // 8 x 6 raycast pixels (fx 5, cx 3.5); camera x = (u - 3.5) / 5 * 1.2 < -0.5 m for u <= 1:
  // those 2 columns' final cells are unobserved.
  EXPECT_EQ(counts.sampled, 48u);
  EXPECT_EQ(counts.no_scene, 0u);
  EXPECT_EQ(counts.no_ssao, 0u);
  EXPECT_EQ(counts.no_mvao, 1u);
  EXPECT_EQ(counts.no_final, 12u);
  EXPECT_EQ(counts.compared, 48u - 1u - 12u);
  EXPECT_EQ(c.count(Region::kAll), counts.compared);
  // Border 2 px: frame pixels (2u, 2v) with u = 0 or 7, or v = 0 or 5; of the compared (u >= 2)
  // pixels, those with v = 0 or 5 (6 columns x 2) or u = 7 (4 more rows).
  EXPECT_EQ(c.count(Region::kBorder), 6u * 2u + 4u);
  EXPECT_EQ(c.count(Region::kDiscontinuity), 0u);  // one flat wall
  EXPECT_DOUBLE_EQ(c.mean(Region::kAll, Shown::kSsao), 0.5);
  EXPECT_DOUBLE_EQ(c.mean(Region::kAll, Shown::kMvao), 0.75);
  EXPECT_DOUBLE_EQ(c.mean(Region::kAll, Shown::kFinal), 0.25);
  EXPECT_DOUBLE_EQ(c.mean_reference(Region::kAll), 1.0);  // nothing occludes an open wall
}

TEST(ImageEval, CellConstantCeilingIsTheCorrelationRatioOfTheReferenceByCell) {
  // Two cells: references (0, 1) in cell 1 (mean 0.5) and (2, 2) in cell 2 (mean 2). Over all
  // four, r of (0.5, 0.5, 2, 2) with (0, 1, 2, 2): summed products of deviations 2.25, summed
  // squares 2.25 and 2.75, r = sqrt(9 / 11).
  const std::vector<CellSample> samples = {
      {1, 0.0, true, false}, {1, 1.0, false, false}, {2, 2.0, true, true}, {2, 2.0, false, true}};
  const std::array<double, kRegionCount> r = cell_constant_ceiling(samples);
  EXPECT_NEAR(r[0], std::sqrt(9.0 / 11.0), 1e-12);
  // Border: (0.5, 2) against (0, 2): r = 1. Discontinuity: both references 2: r = 0.
  EXPECT_NEAR(r[1], 1.0, 1e-12);
  EXPECT_EQ(r[2], 0.0);
}

TEST(ImageEval, ASavedGridReadsBackCellForCell) {
  SavedGrid saved;
  saved.cell_size_m = 0.0078125;
  saved.integration = 1;  // mean
  saved.frames = 7;
  saved.cells = {{-3, 0, 5, 1.5f, 2.0f, 4}, {1, 2, 3, 0.2f, 1.0f, 7}};
  const MvaoGrid grid = grid_from_saved(saved);
  EXPECT_EQ(grid.cell_size_m(), 0.0078125);
  EXPECT_EQ(grid.integration(), AoIntegration::kMean);
  EXPECT_EQ(grid.frames_integrated(), 7u);
  EXPECT_EQ(grid.cell_count(), 2u);
  EXPECT_EQ(*grid.cell_ao({-3, 0, 5}), 0.75f);
  EXPECT_EQ(grid.find({1, 2, 3})->last_frame, 7u);
  EXPECT_EQ(*grid.cell_of(Eigen::Vector3d(-0.02, 0.001, 0.04)), (CellIndex{-3, 0, 5}));
  saved.integration = 3;
  EXPECT_THROW(grid_from_saved(saved), Error);
}

TEST(ImageEval, SceneDepthIsTheOpticalAxisDistanceAndZeroWhereNothingIsHit) {
  const AnalyticScene scene = AnalyticScene::make("plane");
  ImageEvalFrame f = plane_frame();
  const Image<float> depth = scene_depth(scene, f.intrinsics, f.T_scene_camera);
  for (std::size_t i = 0; i < depth.size(); ++i) EXPECT_NEAR(depth.data()[i], 1.2f, 1e-5f);
  // Turned to look away from the wall: no surface anywhere.
  const Eigen::Matrix3d away = f.T_scene_camera.rotation() *
                               Eigen::AngleAxisd(EIGEN_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Image<float> none = scene_depth(scene, f.intrinsics, Pose(away, f.T_scene_camera.translation()));
  for (std::size_t i = 0; i < none.size(); ++i) EXPECT_EQ(none.data()[i], 0.0f);
}

TEST(ImageEval, TemporalStabilityIsTheSpreadOverFramesOfEachCellsPerFrameMean) {
  const Intrinsics k = camera(4, 2, 1, 1.5, 0.5);
  // 10 m cells; the camera at (5, 5, 4): every point at depth 1 lies in cell (0, 0, 0).
  TemporalStability s(10.0);
  const Pose pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(5, 5, 4));
  Image<float> depth(4, 2, 1.0f), ssao(4, 2), mvao(4, 2, 0.5f);
  for (int x = 0; x < 4; ++x) {
    ssao(x, 0) = 0.1f;
    ssao(x, 1) = 0.3f;  // frame mean 0.2
  }
  depth(3, 1) = 100.0f;  // point (155, 55, 104), cell (15, 5, 10): seen in this frame only
  ssao(3, 1) = 0.2f;
  ssao(3, 0) = kNaN;  // no SSAO: left out
  // First cell: pixels (0..2, 0) at 0.1 and (0..2, 1) at 0.3: mean 0.2.
  s.add(k, pose, depth, ssao, mvao);
  Image<float> depth2(4, 2, 1.0f), ssao2(4, 2, 0.6f), mvao2(4, 2, 0.7f);
  depth2(0, 0) = 0.0f;  // no depth: left out
  mvao2(1, 0) = kNaN;   // unobserved: left out
  s.add(k, pose, depth2, ssao2, mvao2);
  EXPECT_EQ(s.frames(), 2u);
  const TemporalStability::Spread two = s.result(2).all;
  ASSERT_EQ(two.cells, 1u);
  EXPECT_NEAR(two.std_mean[0], 0.2, 1e-6);  // SSAO: frames 0.2 and 0.6
  EXPECT_NEAR(two.std_mean[1], 0.1, 1e-6);  // MVAO: frames 0.5 and 0.7
  EXPECT_NEAR(two.std_median[0], 0.2, 1e-6);
  EXPECT_EQ(two.std_mean[2], 0.0);  // no final grid
  EXPECT_DOUBLE_EQ(two.frames_per_cell_mean, 2.0);
  EXPECT_EQ(s.result(2).occluded.cells, 0u);  // occluded needs a final grid
  const TemporalStability::Spread one = s.result(1).all;
  EXPECT_EQ(one.cells, 2u);
  EXPECT_NEAR(one.std_mean[0], 0.1, 1e-6);  // 0.2 and 0 (one frame)
  EXPECT_NEAR(one.std_median[0], 0.1, 1e-6);
  EXPECT_EQ(s.result(3).all.cells, 0u);
  EXPECT_THROW(TemporalStability(0.0), Error);
}

TEST(ImageEval, TemporalStabilityPlacesARaycastDepthAtAPyramidLevelOfTheViews) {
  // Views of 4 x 2 pixels, the model raycast at level 1 (2 x 1): fx 0.5, cx 0.5, cy 0. Raycast
  // pixel x = 0 is view pixel (0, 0) and the point (-z, 0, z); x = 1 is view pixel (2, 0) and
  // (z, 0, z). 1 m cells: depth 1.5 puts them in cells x = -2 and x = 1.
  const Intrinsics k = camera(4, 2, 1, 1.5, 0.5);
  TemporalStability s(1.0);
  Image<float> ssao(4, 2, kNaN), mvao(4, 2, 0.5f);
  ssao(0, 0) = 0.1f;
  ssao(2, 0) = 0.3f;
  s.add(k, Pose(), Image<float>(2, 1, 1.5f), ssao, mvao);
  ssao(0, 0) = 0.2f;
  s.add(k, Pose(), Image<float>(2, 1, 1.5f), ssao, mvao);
  const TemporalStability::Spread spread = s.result(2).all;
  ASSERT_EQ(spread.cells, 2u);
  EXPECT_NEAR(spread.std_mean[0], (0.05 + 0.0) / 2, 1e-6);
  EXPECT_EQ(spread.std_mean[1], 0.0);
  // A depth image that is neither the views' size nor a pyramid level of it is refused.
  EXPECT_THROW(s.add(k, Pose(), Image<float>(3, 1, 1.5f), ssao, mvao), Error);
  EXPECT_THROW(s.add(k, Pose(), Image<float>(2, 2, 1.5f), ssao, mvao), Error);
}

TEST(ImageEval, TemporalStabilityWithAFinalGridReadsItAtEachPointAndSplitsOccludedCells) {
  const Intrinsics k = camera(2, 1, 1, 0.25, 0);
  // 1 m cells for the spread, 0.5 m cells in the grid. Camera at the origin: depth 2 puts
  // pixel 0 at (-0.5, 0, 2) and pixel 1 at (1.5, 0, 2); depth 2.6 at x = -0.65 and 1.95. Each
  // pixel stays in one spread cell but moves to another grid cell.
  MvaoGrid grid = half_metre_grid();
  ASSERT_TRUE(grid.restore_cell({-1, 0, 4}, {0.5f, 1.0f, 1}));  // x in [-0.5, 0), z in [2, 2.5)
  ASSERT_TRUE(grid.restore_cell({-2, 0, 5}, {0.7f, 1.0f, 1}));  // x in [-1, -0.5), z in [2.5, 3)
  ASSERT_TRUE(grid.restore_cell({3, 0, 4}, {0.95f, 1.0f, 1}));
  ASSERT_TRUE(grid.restore_cell({3, 0, 5}, {0.95f, 1.0f, 1}));
  const FinalGrid final_grid(grid);
  TemporalStability s(1.0);
  const Image<float> ssao(2, 1, 0.5f), mvao(2, 1, 0.6f);
  s.add(k, Pose(), Image<float>(2, 1, 2.0f), ssao, mvao, &final_grid);
  s.add(k, Pose(), Image<float>(2, 1, 2.6f), ssao, mvao, &final_grid);
  // Spread cell (-1, 0, 2) saw 0.5 then 0.7: spread 0.1; cell (1, 0, 2) saw 0.95 twice. SSAO and
  // MVAO did not change.
  const TemporalStability::Result r = s.result(2);
  ASSERT_EQ(r.all.cells, 2u);
  EXPECT_NEAR(r.all.std_mean[2], 0.05, 1e-6);
  EXPECT_EQ(r.all.std_mean[0], 0.0);
  EXPECT_EQ(r.all.std_mean[1], 0.0);
  ASSERT_EQ(r.occluded.cells, 1u);  // mean final 0.6 < 0.9; the other 0.95
  EXPECT_NEAR(r.occluded.std_mean[2], 0.1, 1e-6);
  // MVAO shown 0.6 against final 0.5 and 0.95, then 0.7 and 0.95: all four differ.
  ASSERT_EQ(s.final_differences().size(), 2u);
  EXPECT_EQ(s.final_differences()[0].pixels, 2u);
  EXPECT_NEAR(s.final_differences()[0].mean_abs, (0.1 + 0.35) / 2, 1e-6);
  EXPECT_NEAR(s.final_differences()[1].mean_abs, (0.1 + 0.35) / 2, 1e-6);
  EXPECT_EQ(s.final_differences()[1].share_differing, 1.0);
  // A pixel whose point has no observed cell in the final grid is left out altogether.
  TemporalStability t(1.0);
  t.add(k, Pose(), Image<float>(2, 1, 3.5f), ssao, mvao, &final_grid);
  EXPECT_EQ(t.result(1).all.cells, 0u);
}

TEST(ImageEval, TrackedPointsReadTheViewsBilinearlyWhereTheRaycastShowsThem) {
  // Views of 8 x 6 pixels, the model raycast at level 1 (4 x 3, f 2, cx 1.5, cy 1): a plane at
  // z = 2 seen from the origin (frame A) and from (0.4, 0, 0) (frame B). Raycast pixel (u, v)
  // shows world x = (u - 1.5) + camera x, y = v - 1.
  const Intrinsics k = camera(8, 6, 4, 3.5, 2.5);
  const Image<float> depth(4, 3, 2.0f);
  // SSAO 0.5 + 0.1 x at each raycast pixel's world point, replicated over its 2 x 2 view pixels:
  // linear in x, so read bilinearly at a point it is that point's value in every frame.
  const auto views = [&](double camera_x, float mvao_value) {
    std::pair<Image<float>, Image<float>> v{Image<float>(8, 6), Image<float>(8, 6, mvao_value)};
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 8; ++x)
        v.first(x, y) = static_cast<float>(0.5 + 0.1 * ((x / 2 - 1.5) + camera_x));
    return v;
  };
  const Pose a, b(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.4, 0, 0));
  const std::vector<Eigen::Vector3f> points = {
      {0.1f, 0.05f, 2.0f},   // seen by A at (1.6, 1.05) and by B at (1.2, 1.05)
      {-1.2f, 0.0f, 2.0f},   // seen by A at (0.3, 1); outside B's raycast
      {0.1f, 0.05f, 2.5f}};  // behind the plane: seen by neither
  MvaoGrid grid = half_metre_grid();
  for (int x = -4; x <= 3; ++x)
    for (int y = -2; y <= 2; ++y) ASSERT_TRUE(grid.restore_cell({x, y, 4}, {0.7f, 1.0f, 1}));
  const FinalGrid final_grid(grid);
  TemporalStability s(1.0);
  const auto [ssao_a, mvao_a] = views(0.0, 0.6f);
  const auto [ssao_b, mvao_b] = views(0.4, 0.8f);
  s.add_tracked(k, a, depth, ssao_a, mvao_a, points, &final_grid);
  s.add_tracked(k, b, depth, ssao_b, mvao_b, points, &final_grid);
  // A frame where one of the four raycast pixels around the first point has no surface does not
  // see it.
  Image<float> holed = depth;
  holed(2, 1) = 0.0f;
  s.add_tracked(k, b, holed, ssao_b, mvao_b, points, &final_grid);
  EXPECT_EQ(s.frames(), 3u);
  const TemporalStability::Result two = s.result(2);
  ASSERT_EQ(two.all.cells, 1u);
  EXPECT_DOUBLE_EQ(two.all.frames_per_cell_mean, 2.0);
  // The nearest pixel would read 0.55 in A and 0.49 in B (a spread of 0.03).
  EXPECT_NEAR(two.all.std_mean[0], 0.0, 1e-6);
  EXPECT_NEAR(two.all.std_mean[1], 0.1, 1e-6);  // MVAO 0.6, then 0.8
  EXPECT_NEAR(two.all.std_mean[2], 0.0, 1e-6);  // the final grid, 0.7 wherever it is read
  EXPECT_EQ(two.occluded.cells, 1u);
  EXPECT_EQ(s.result(1).all.cells, 2u);
  EXPECT_EQ(s.result(3).all.cells, 0u);
  // A pixel whose point has no observed cell in the final grid hides the point.
  TemporalStability t(1.0);
  const MvaoGrid empty = half_metre_grid();
  const FinalGrid unobserved(empty);
  t.add_tracked(k, a, depth, ssao_a, mvao_a, points, &unobserved);
  EXPECT_EQ(t.result(1).all.cells, 0u);
  // Cells and tracked points do not mix in one measure.
  EXPECT_THROW(s.add(k, a, depth, ssao_a, mvao_a), Error);
  TemporalStability u(1.0);
  u.add(k, a, depth, ssao_a, mvao_a);
  EXPECT_THROW(u.add_tracked(k, a, depth, ssao_a, mvao_a, points), Error);
}

TEST(ImageEval, ATrackedPointsViewsSoFarAreTheMeanOfEveryFrameThatSawIt) {
  // One point straight ahead at 2 m, seen by three frames showing SSAO 0.2, 0.4, 0.9; the second
  // frame is not measured. The views so far read 0.2, (0.3), 0.5 in turn.
  const Intrinsics k = camera(8, 6, 4, 3.5, 2.5);
  const Image<float> depth(4, 3, 2.0f), mvao(8, 6, 0.5f);
  const std::vector<Eigen::Vector3f> points = {{0.1f, 0.05f, 2.0f}};
  TemporalStability s(1.0);
  s.add_tracked(k, Pose(), depth, Image<float>(8, 6, 0.2f), mvao, points);
  s.add_tracked(k, Pose(), depth, Image<float>(8, 6, 0.4f), mvao, points, nullptr, false);
  s.add_tracked(k, Pose(), depth, Image<float>(8, 6, 0.9f), mvao, points);
  EXPECT_EQ(s.frames(), 2u);  // the measured ones
  const TemporalStability::Spread spread = s.result(2).all;
  ASSERT_EQ(spread.cells, 1u);
  EXPECT_DOUBLE_EQ(spread.frames_per_cell_mean, 2.0);
  EXPECT_NEAR(spread.std_mean[0], 0.35, 1e-6);                               // SSAO 0.2 and 0.9
  EXPECT_NEAR(spread.std_mean[TemporalStability::kViewsSoFar], 0.15, 1e-6);  // 0.2 and 0.5
  EXPECT_EQ(spread.std_mean[1], 0.0);
}

}  // namespace
}  // namespace aoscan::eval
