// Bad input through the whole chain (issues #3 and #4): invalid, absurd and jumping frames from a
// synthetic corner orbit (exact depth), empty raycasts reaching SSAO and MVAO, MVAO cells beyond
// the Morton range, NaN / inf in the float maps; checked on the files a run leaves (stats.json,
// trajectory.txt, mesh.ply): exact lost counts, finite poses, AO in [0, 1] and never NaN.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "capture/source.h"
#include "fusion/preprocess/pyramid.h"
#include "io/ply.h"
#include "io/tum.h"
#include "pipeline/config.h"
#include "pipeline/list_source.h"
#include "pipeline/processing.h"
#include "pipeline/session.h"
#include "support/scratch_dir.h"
#include "support/synth_frames.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;
using test::frames;
using test::ListSource;

struct RunFiles {
  SessionResult result;
  nlohmann::json stats;
  std::vector<StampedPose> trajectory;
  TriangleMesh mesh;
};

/// Replays `list` into the folder `name` of the test's scratch folder and reads the outputs back.
RunFiles run(const testing::ScratchDir& scratch, const std::string& name,
             std::vector<DepthFrame> list, const Config& config = {}) {
  ListSource source(std::move(list));
  RunOptions options;
  options.config = config;
  options.out_dir = scratch.file(name);
  options.threads = 2;
  std::atomic<bool> stop{false};
  RunFiles files;
  files.result = run_session(source, options, stop);
  std::ifstream in(fs::path(options.out_dir) / "stats.json");
  files.stats = nlohmann::json::parse(in);
  files.trajectory = read_trajectory((fs::path(options.out_dir) / "trajectory.txt").string());
  files.mesh = read_ply((fs::path(options.out_dir) / "mesh.ply").string());
  return files;
}

/// Every pose finite, every mesh value finite, AO in [0, 1].
void expect_finite_outputs(const RunFiles& f) {
  for (const StampedPose& p : f.trajectory) EXPECT_TRUE(p.T_world_camera.finite());
  ASSERT_EQ(f.mesh.quality.size(), f.mesh.vertices.size());
  for (std::size_t i = 0; i < f.mesh.vertices.size(); ++i) {
    ASSERT_TRUE(f.mesh.vertices[i].allFinite()) << i;
    ASSERT_TRUE(f.mesh.normals[i].allFinite()) << i;
    ASSERT_TRUE(f.mesh.quality[i] >= 0.0f && f.mesh.quality[i] <= 1.0f) << f.mesh.quality[i];
  }
}

std::size_t lost(const RunFiles& f) {
  return f.stats["frames_tracking_lost"].get<std::size_t>();
}

TEST(BadInput, AllInvalidFramesAreCountedAsLost) {
  aoscan::testing::ScratchDir scratch;
  std::vector<DepthFrame> list = frames(0, 20);
  for (int i = 8; i < 13; ++i) list[i].depth.fill(0);
  const RunFiles f = run(scratch, "invalid", list);
  EXPECT_EQ(f.result.exit_code, ExitCode::kOk) << f.result.error;
  EXPECT_EQ(f.stats["frames_processed"], 20);
  EXPECT_EQ(lost(f), 5u);
  EXPECT_EQ(f.stats["tracking_losses"], 1);  // lost once, for five frames ...
  EXPECT_EQ(f.stats["relocalisations"], 1);  // ... and back with the first frame with depth
  EXPECT_GT(f.stats["keyframes"].get<int>(), 0);
  ASSERT_EQ(f.trajectory.size(), 15u);
  for (const StampedPose& p : f.trajectory)  // the lost frames have no line
    EXPECT_FALSE(p.timestamp_s > 7.5 / 30.0 && p.timestamp_s < 12.5 / 30.0) << p.timestamp_s;
  EXPECT_GT(f.mesh.faces.size(), 1000u);
  expect_finite_outputs(f);
}

TEST(BadInput, AHandfulOfValidPixelsIsLost) {
  aoscan::testing::ScratchDir scratch;
  std::vector<DepthFrame> list = frames(0, 16);
  for (int i = 8; i < 11; ++i)  // 48 valid pixels on a sparse 8x6 lattice
    for (int y = 0; y < 240; ++y)
      for (int x = 0; x < 320; ++x)
        if (x % 40 != 20 || y % 40 != 20) list[i].depth(x, y) = 0;
  const RunFiles f = run(scratch, "handful", list);
  EXPECT_EQ(f.result.exit_code, ExitCode::kOk) << f.result.error;
  EXPECT_EQ(lost(f), 3u);
  EXPECT_EQ(f.trajectory.size(), 13u);
  expect_finite_outputs(f);
}

TEST(BadInput, AbsurdRawDepthsAreClippedAndLost) {
  aoscan::testing::ScratchDir scratch;
  std::vector<DepthFrame> list = frames(0, 16);
  for (int i = 6; i < 8; ++i) list[i].depth.fill(65535);  // the sensor's "invalid"
  for (int i = 8; i < 10; ++i) {                          // 60 m everywhere
    list[i].depth_scale = 1000.0;
    list[i].depth.fill(60000);
  }
  list[10].depth_scale = 1e-30;  // every depth ~1e33 m
  const RunFiles f = run(scratch, "absurd", list);
  EXPECT_EQ(f.result.exit_code, ExitCode::kOk) << f.result.error;
  EXPECT_EQ(lost(f), 5u);
  EXPECT_EQ(f.trajectory.size(), 11u);
  EXPECT_FALSE(f.stats["tsdf"]["capacity_reached"].get<bool>());
  expect_finite_outputs(f);
}

TEST(BadInput, UnusableDepthScaleStopsWithExitThreeNamingTheFrame) {
  aoscan::testing::ScratchDir scratch;
  std::vector<DepthFrame> list = frames(0, 10);
  list[6].depth_scale = std::numeric_limits<double>::quiet_NaN();
  const RunFiles f = run(scratch, "nan_scale", list);
  EXPECT_EQ(f.result.exit_code, ExitCode::kBadInput);
  EXPECT_NE(f.result.error.find("frame 6"), std::string::npos) << f.result.error;
  EXPECT_EQ(f.result.error.find('\n'), std::string::npos);
  EXPECT_EQ(f.trajectory.size(), 6u);  // what was fused before is written
  EXPECT_GT(f.mesh.faces.size(), 100u);
  expect_finite_outputs(f);
}

TEST(BadInput, AFarJumpWithoutReturnStaysLostAndIsReported) {
  aoscan::testing::ScratchDir scratch;
  // 170 frames ahead on the orbit: 1.1 m and 27 degrees away, beyond tracking's reach.
  const RunFiles f = run(scratch, "jump", frames(0, 12, 182, 190));
  EXPECT_EQ(f.result.exit_code, ExitCode::kOk) << f.result.error;
  EXPECT_EQ(lost(f), 8u);
  EXPECT_EQ(f.stats["tracking_losses"], 1);
  EXPECT_EQ(f.stats["relocalisations"], 0);  // nothing mapped there: it stays lost
  EXPECT_EQ(f.trajectory.size(), 12u);
  expect_finite_outputs(f);
}

TEST(BadInput, AFarJumpAndBackRecovers) {
  aoscan::testing::ScratchDir scratch;
  std::vector<DepthFrame> list = frames(0, 12, 182, 186);  // 4 frames far ahead ...
  const std::vector<DepthFrame> back = frames(12, 20);     // ... then back where it left off
  list.insert(list.end(), back.begin(), back.end());
  // Delivered in this order, the frames' times follow it too (a recording's must increase).
  for (std::size_t i = 0; i < list.size(); ++i) list[i].timestamp_s = static_cast<double>(i) / 30;
  const RunFiles f = run(scratch, "jump_back", list);
  EXPECT_EQ(lost(f), 4u);
  EXPECT_EQ(f.stats["tracking_losses"], 1);
  EXPECT_EQ(f.stats["relocalisations"], 1);
  ASSERT_EQ(f.trajectory.size(), 20u);
  const Pose T_truth0_world = test::corner_frame(0).T_world_camera_gt->inverse();
  for (int i = 0; i < 20; ++i) {  // line i is frame i
    const Pose truth = T_truth0_world * *test::corner_frame(i).T_world_camera_gt;
    EXPECT_LT((f.trajectory[i].T_world_camera.translation() - truth.translation()).norm(), 0.005)
        << i;
  }
  expect_finite_outputs(f);
}

TEST(BadInput, EmptyFirstFramesAreLostAndTheModelStartsAfterThem) {
  aoscan::testing::ScratchDir scratch;
  std::vector<DepthFrame> list = frames(0, 12);
  for (int i = 0; i < 4; ++i) list[i].depth.fill(0);
  const RunFiles f = run(scratch, "empty_start", list);
  EXPECT_EQ(f.result.exit_code, ExitCode::kOk) << f.result.error;
  EXPECT_EQ(lost(f), 4u);
  EXPECT_EQ(f.stats["tracking_losses"], 0);  // no model yet: nothing to lose
  EXPECT_EQ(f.stats["relocalisations"], 0);
  ASSERT_EQ(f.trajectory.size(), 8u);
  // The world frame is the camera frame of the first frame with depth (frame 4).
  EXPECT_NEAR(f.trajectory[0].timestamp_s, 4.0 / 30.0, 1e-6);
  EXPECT_TRUE(f.trajectory[0].T_world_camera.matrix().isIdentity(1e-9));
  const Pose T_truth4_world = test::corner_frame(4).T_world_camera_gt->inverse();
  for (int i = 0; i < 8; ++i) {
    const Pose truth = T_truth4_world * *test::corner_frame(4 + i).T_world_camera_gt;
    EXPECT_LT((f.trajectory[i].T_world_camera.translation() - truth.translation()).norm(), 0.005)
        << i;
  }
  EXPECT_GT(f.mesh.faces.size(), 1000u);
  expect_finite_outputs(f);
}

TEST(BadInputAo, EmptyRaycastsReachSsaoAndMvaoWithoutHarm) {
  aoscan::testing::ScratchDir scratch;
  // A raycast range that holds no surface: every model raycast is empty, so SSAO and MVAO get
  // empty maps (frame 0 is fused and its empty raycast goes downstream; frame 1 is tracked
  // against frame 0's own filtered maps, as the second frame of every model is; every later
  // frame has nothing to track against and is lost).
  Config config;
  config.fusion.raycast_max_depth_m = 0.3;
  const RunFiles f = run(scratch, "empty_raycast", frames(0, 6), config);
  EXPECT_EQ(f.result.exit_code, ExitCode::kOk) << f.result.error;
  EXPECT_EQ(lost(f), 4u);
  ASSERT_EQ(f.trajectory.size(), 2u);
  EXPECT_EQ(f.stats["mvao_grid"]["cells"], 0);
  EXPECT_EQ(f.stats["mvao_grid"]["bricks"], 0);
  EXPECT_EQ(f.stats["mvao_grid"]["memory_mb"], 0.0);  // nothing held without a cell
  ASSERT_GT(f.mesh.vertices.size(), 100u);  // frame 0's surface, never seen by SSAO
  EXPECT_EQ(f.stats["mesh"]["ao_unobserved_vertices"].get<std::size_t>(), f.mesh.vertices.size());
  for (float q : f.mesh.quality) ASSERT_EQ(q, 1.0f);
  expect_finite_outputs(f);
}

TEST(BadInputAo, PointsBeyondTheMortonRangeAreCountedNotWrapped) {
  aoscan::testing::ScratchDir scratch;
  // Cells of 1e-3 / 2^20 m: the Morton range (+-2^20 cells) spans +-1 mm around the world
  // origin, and every surface point lies beyond it.
  Config config;
  config.ao.grid_resolution = 1 << 20;
  config.ao.grid_extent_m = 1e-3;
  const RunFiles f = run(scratch, "morton", frames(0, 4), config);
  EXPECT_EQ(f.result.exit_code, ExitCode::kOk) << f.result.error;
  EXPECT_EQ(f.stats["mvao_grid"]["cells"], 0);
  EXPECT_GT(f.stats["mvao_grid"]["points_out_of_range"].get<std::uint64_t>(), 10000u);
  EXPECT_EQ(f.stats["mesh"]["ao_unobserved_vertices"].get<std::size_t>(), f.mesh.vertices.size());
  expect_finite_outputs(f);
}

/// Runs the chain's stages in order on one thread, poisoning the float maps of frames 5-7 after
/// the filter stage (every 5th pixel NaN, inf, 1e30, -1 in turn; pyramid rebuilt), then writes
/// the outputs. Returns the mesh as written.
TriangleMesh run_poisoned(const Config& config, const std::string& out_dir) {
  Processing processing(config, out_dir);
  const std::vector<StageDef> stages = processing.stages();
  const float poison[] = {std::numeric_limits<float>::quiet_NaN(),
                          std::numeric_limits<float>::infinity(), 1e30f, -1.0f};
  for (int i = 0; i < 12; ++i) {
    FrameWork work;
    work.raw = test::corner_frame(i);
    for (const StageDef& stage : stages) {
      EXPECT_TRUE(stage.process(work).is_ok()) << stage.name << " frame " << i;
      if (stage.name == "filter" && i >= 5 && i < 8) {
        int k = 0;
        for (Image<float>* img : {&work.pre.depth_m, &work.pre.filtered_m})
          for (std::size_t p = 0; p < img->size(); p += 5) img->data()[p] = poison[k++ % 4];
        build_pyramid(work.pre.filtered_m, work.raw.intrinsics, config.preprocess,
                      work.pre.pyramid);
      }
    }
  }
  EXPECT_EQ(processing.frames_tracking_lost(), 0u);
  for (const StampedPose& p : processing.trajectory()) EXPECT_TRUE(p.T_world_camera.finite());
  return *processing.final_mesh().mesh;
}

TEST(BadInputAo, NonFiniteMapsNeverReachMeshAo) {
  aoscan::testing::ScratchDir scratch;
  for (AoInput input : {AoInput::kRaycast, AoInput::kRaw}) {
    Config config;
    config.ao.input = input;
    const std::string dir = scratch.file(input == AoInput::kRaw ? "poison_raw" : "poison_raycast");
    const TriangleMesh mesh = run_poisoned(config, dir);
    ASSERT_GT(mesh.faces.size(), 1000u);
    ASSERT_EQ(mesh.quality.size(), mesh.vertices.size());
    std::size_t occluded = 0;
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
      ASSERT_TRUE(mesh.vertices[i].allFinite());
      ASSERT_TRUE(mesh.quality[i] >= 0.0f && mesh.quality[i] <= 1.0f) << mesh.quality[i];
      occluded += mesh.quality[i] < 0.9f;
    }
    EXPECT_GT(occluded, 0u) << "the corner's AO must still be computed";
  }
}

}  // namespace
}  // namespace aoscan
