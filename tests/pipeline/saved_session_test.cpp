// Tests for src/pipeline/saved_session.cpp through whole sessions: a take saved with
// --save-session and continued by a second take that starts elsewhere in the scanned space
// (--resume), in the first take's world frame; and every refusal: no session, an unfinished or
// damaged one, another format version, another voxel size, another camera.
#include "pipeline/saved_session.h"

#include <filesystem>
#include <fstream>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "io/ply.h"
#include "io/tum.h"
#include "pipeline/list_source.h"
#include "pipeline/session.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

struct Take {
  SessionResult result;
  nlohmann::json stats;
  std::vector<StampedPose> trajectory;
};

/// Runs `list` into `out` (saving the session), continuing the session in `resume` when given.
Take run(const std::string& out, std::vector<DepthFrame> list, const std::string& resume = "",
         const Config& config = {}) {
  test::ListSource source(std::move(list));
  RunOptions options;
  options.config = config;
  options.out_dir = out;
  options.threads = 2;
  options.save_session = true;
  options.resume_dir = resume;
  std::atomic<bool> stop{false};
  Take take;
  take.result = run_session(source, options, stop);
  std::ifstream in(fs::path(out) / "stats.json");
  take.stats = nlohmann::json::parse(in);
  take.trajectory = read_trajectory((fs::path(out) / "trajectory.txt").string());
  return take;
}

/// The second take's frames: it starts 24 frames (about 35 cm) back along the first take's path
/// and goes on past its end.
std::vector<DepthFrame> second_take() { return test::frames(16, 56); }

TEST(SavedSession, ASecondTakeContinuesInTheFirstTakesWorld) {
  testing::ScratchDir scratch;
  const Take first = run(scratch.file("one"), test::frames(0, 40));
  ASSERT_EQ(first.result.exit_code, ExitCode::kOk) << first.result.error;
  for (const std::string& name : session_outputs())
    EXPECT_TRUE(fs::is_regular_file(fs::path(scratch.file("one")) / name)) << name;
  EXPECT_GT(first.stats["files"].size(), 6u);

  const Take second = run(scratch.file("two"), second_take(), scratch.file("one"));
  ASSERT_EQ(second.result.exit_code, ExitCode::kOk) << second.result.error;
  EXPECT_EQ(second.stats["relocalisations"], 1);  // the first frame, against the keyframes
  EXPECT_LE(second.stats["frames_tracking_lost"].get<int>(), 2);
  // The trajectory holds both takes; the second one's poses lie in the first one's world.
  ASSERT_EQ(second.trajectory.size(), 40u + 40u - second.stats["frames_tracking_lost"].get<std::size_t>());
  const Pose T_truth0_world = test::corner_frame(0).T_world_camera_gt->inverse();
  for (std::size_t i = 40; i < second.trajectory.size(); ++i) {
    // Take two's timestamps are its own frames' (frame k at k / 30 s).
    const int frame = static_cast<int>(std::lround(second.trajectory[i].timestamp_s * 30.0));
    const Pose truth = T_truth0_world * *test::corner_frame(frame).T_world_camera_gt;
    EXPECT_LT(translation_between(second.trajectory[i].T_world_camera, truth), 0.01) << frame;
    EXPECT_LT(rotation_between_deg(second.trajectory[i].T_world_camera, truth), 0.5) << frame;
  }
  // The first take's lines are carried over as they were.
  for (std::size_t i = 0; i < first.trajectory.size(); ++i)
    EXPECT_TRUE(second.trajectory[i].T_world_camera.matrix().isApprox(
        first.trajectory[i].T_world_camera.matrix(), 1e-9));
  // The saved session now says two takes; a third take continues it into the same folder, whose
  // earlier session goes to previous/.
  const fs::path two = scratch.file("two");
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(two / "session" / "session.json"))["takes"], 2);
  const Take third = run(two.string(), test::frames(40, 48), two.string());
  ASSERT_EQ(third.result.exit_code, ExitCode::kOk) << third.result.error;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(two / "session" / "session.json"))["takes"], 3);
  EXPECT_TRUE(fs::is_regular_file(two / "previous" / "session" / "session.json"));
  EXPECT_EQ(third.trajectory.size(), second.trajectory.size() + 8);
}

// The fused colour is part of the session: a take with colour saved, then continued by a take
// without colour, still meshes the first take's surface in its colour (what it did not see again
// keeps the colour it had; what only the second take saw has none).
TEST(SavedSession, TheFusedColourIsSavedAndContinued) {
  testing::ScratchDir scratch;
  constexpr Rgb8 kPaint{180, 90, 30};
  std::vector<DepthFrame> coloured = test::frames(0, 40);
  for (DepthFrame& f : coloured) {
    f.colour = Image<Rgb8>(f.intrinsics.width, f.intrinsics.height, kPaint);
    f.colour_camera = ColourCamera::registered_to(f.intrinsics);
  }
  const Take first = run(scratch.file("one"), coloured);
  ASSERT_EQ(first.result.exit_code, ExitCode::kOk) << first.result.error;
  const TriangleMesh one = read_ply(scratch.file("one") + "/mesh.ply");
  const Take second = run(scratch.file("two"), second_take(), scratch.file("one"));
  ASSERT_EQ(second.result.exit_code, ExitCode::kOk) << second.result.error;
  const TriangleMesh two = read_ply(scratch.file("two") + "/mesh.ply");
  const auto painted = [&](const TriangleMesh& mesh) {
    std::size_t n = 0;
    for (const Rgb8& c : mesh.colours) n += c == kPaint;
    return n;
  };
  ASSERT_EQ(one.colours.size(), one.vertices.size());
  EXPECT_GT(painted(one), one.vertices.size() * 9 / 10);
  ASSERT_EQ(two.colours.size(), two.vertices.size()) << "the resumed take lost the colour";
  // The second take sees part of the first one's surface again and some new surface.
  EXPECT_GT(painted(two), painted(one) * 8 / 10);
  EXPECT_LT(painted(two), two.vertices.size());
  EXPECT_EQ(second.stats["mesh"]["coloured"], true);
}

/// Makes a saved session in `dir` from a short take.
void save_short_take(const std::string& dir) {
  const Take t = run(dir, test::frames(0, 16));
  ASSERT_EQ(t.result.exit_code, ExitCode::kOk) << t.result.error;
}

/// The error a resume from `dir` gives, checking that the output folder was not touched.
std::string refused(const testing::ScratchDir& scratch, const std::string& dir,
                    ExitCode expected, const Config& config = {},
                    std::vector<DepthFrame> list = test::frames(0, 4)) {
  test::ListSource source(std::move(list));
  RunOptions options;
  options.config = config;
  options.out_dir = scratch.file("refused");
  options.resume_dir = dir;
  std::atomic<bool> stop{false};
  const std::string message =
      testing::error_message([&] { run_session(source, options, stop); }, expected);
  EXPECT_FALSE(fs::exists(options.out_dir)) << "a refused --resume wrote " << options.out_dir;
  return message;
}

TEST(SavedSession, AMissingOrUnfinishedSessionIsRefused) {
  testing::ScratchDir scratch;
  const std::string none = scratch.file("none");
  fs::create_directories(none);
  EXPECT_NE(refused(scratch, none, ExitCode::kBadInput).find("no saved session"),
            std::string::npos);
  const std::string dir = scratch.file("saved");
  save_short_take(dir);
  fs::remove(fs::path(dir) / "session" / "session.json");
  EXPECT_NE(refused(scratch, dir, ExitCode::kBadInput).find("session.json: missing"),
            std::string::npos);
}

TEST(SavedSession, DamagedFilesAreRefusedNamingThem) {
  testing::ScratchDir scratch;
  const std::string dir = scratch.file("saved");
  save_short_take(dir);
  const fs::path session = fs::path(dir) / "session";
  for (const char* name : {"keyframes.db", "mvao.grid"}) {
    const fs::path file = session / name;
    const fs::path keep = session / "keep";
    fs::copy_file(file, keep);
    fs::resize_file(file, fs::file_size(file) - 10);  // truncated
    EXPECT_NE(refused(scratch, dir, ExitCode::kBadInput).find(std::string(name) + ": "),
              std::string::npos)
        << name;
    fs::remove(file);
    fs::rename(keep, file);
  }
  std::ofstream(session / "trajectory.txt") << "0 1 2\n";  // a garbled line
  EXPECT_NE(refused(scratch, dir, ExitCode::kBadInput).find("trajectory.txt"), std::string::npos);
}

TEST(SavedSession, AnotherVersionVoxelSizeOrCameraIsRefused) {
  testing::ScratchDir scratch;
  const std::string dir = scratch.file("saved");
  save_short_take(dir);
  Config finer;
  finer.fusion.voxel_size_m = Config{}.fusion.voxel_size_m / 2;
  const std::string voxel = refused(scratch, dir, ExitCode::kUsage, finer);
  EXPECT_NE(voxel.find("fusion.voxel_size_m"), std::string::npos) << voxel;
  // A camera of another resolution.
  std::vector<DepthFrame> small = test::frames(0, 4);
  for (DepthFrame& f : small) {
    f.intrinsics = f.intrinsics.scaled(1);
    f.depth.resize(f.intrinsics.width, f.intrinsics.height, 0);
  }
  const std::string camera = refused(scratch, dir, ExitCode::kUsage, Config{}, small);
  EXPECT_NE(camera.find("the same camera"), std::string::npos) << camera;
  // A session of a later format.
  const fs::path json = fs::path(dir) / "session" / "session.json";
  nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  j["version"] = kSessionFormatVersion + 1;
  std::ofstream(json) << j.dump();
  const std::string version = refused(scratch, dir, ExitCode::kUsage);
  EXPECT_NE(version.find("session format version"), std::string::npos) << version;
}

}  // namespace
}  // namespace aoscan
