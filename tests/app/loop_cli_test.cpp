// End-to-end tests of `aoscan replay --loop N` and `--progress-every S`.
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace fs = std::filesystem;

namespace {

using aoscan::testing::CliRun;
using aoscan::testing::quote;
using aoscan::testing::read_stats;
using aoscan::testing::read_text;
using aoscan::testing::run_aoscan;

/// The lines of trajectory.txt as (timestamp, tx, ty, tz).
std::vector<std::vector<double>> read_trajectory(const fs::path& file) {
  std::vector<std::vector<double>> poses;
  std::istringstream in(read_text(file));
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> v(4);
    fields >> v[0] >> v[1] >> v[2] >> v[3];
    EXPECT_FALSE(fields.fail()) << line;
    poses.push_back(v);
  }
  return poses;
}

TEST(LoopCli, PassCountOutsideTheRangeExitsTwoNamingIt) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("bad-loop");
  for (const char* n : {"0", "-2", "100001"}) {
    const CliRun r = run_aoscan(
        std::string("replay synth:corner?frames=3 --headless --loop ") + n + " --out " +
            quote((dir / "O").string()),
        dir);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err, std::string("aoscan: error: --loop ") + n +
                         ": the number of passes must be 1 to 100000\n");
  }
  EXPECT_EQ(run_aoscan("replay synth:corner --loop two", dir).exit_code, 2);
}

TEST(LoopCli, PingPongReplayReadsEveryPassAndComesBackToTheStart) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("loop");
  const fs::path rec = aoscan::testing::record_corner(dir, 20, 160, 120);
  const fs::path out = dir / "O";
  const CliRun r = run_aoscan(
      "replay " + quote(rec.string()) + " --headless --loop 3 --out " + quote(out.string()), dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["frames_read"], 60);
  EXPECT_EQ(stats["frames_processed"], 60);
  EXPECT_EQ(stats["frames_tracking_lost"], 0);
  const auto poses = read_trajectory(out / "trajectory.txt");
  ASSERT_EQ(poses.size(), 60u);
  // The recording is at 30 Hz from t = 0: the timestamps go on at 1/30 s through both turns.
  for (std::size_t i = 0; i < poses.size(); ++i)
    EXPECT_NEAR(poses[i][0], static_cast<double>(i) / 30.0, 2e-6) << "line " << i;
  // Position 39 is frame 0 again (the end of the backward pass): the camera is back where it
  // started, and the third pass retraces the first.
  for (int k : {1, 2, 3}) EXPECT_NEAR(poses[39][k], poses[0][k], 0.01) << "axis " << k;
  for (int k : {1, 2, 3}) EXPECT_NEAR(poses[59][k], poses[19][k], 0.01) << "axis " << k;
  for (int k : {1, 2, 3}) EXPECT_NEAR(poses[30][k], poses[9][k], 0.01) << "axis " << k;
}

TEST(LoopCli, FramesCapsTheLoopedTotal) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("loop-frames");
  const fs::path out = dir / "O";
  const CliRun r = run_aoscan(
      "replay " + quote("synth:corner?frames=4&width=64&height=48") +
          " --headless --loop 5 --frames 7 --out " + quote(out.string()),
      dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_stats(out)["frames_read"], 7);
  EXPECT_EQ(read_stats(out)["frames_processed"], 7);
}

TEST(LoopCli, ProgressEveryPrintsOneLineEachWithTheCounts) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("progress");
  const fs::path out = dir / "O";
  const CliRun r = run_aoscan(
      "replay " + quote("synth:corner?frames=6&width=64&height=48") +
          " --headless --progress-every 0.000001 --out " + quote(out.string()),
      dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream in(r.err);
  std::size_t lines = 0;
  std::size_t last = 0;
  for (std::string line; std::getline(in, line);) {
    // Warnings may come between them (at 64 x 48 tracking is lost, and says so).
    if (line.rfind("aoscan: warning: ", 0) == 0) continue;
    std::size_t processed = 0, read = 0, dropped = 0;
    double elapsed = 0;
    ASSERT_EQ(std::sscanf(line.c_str(),
                          "aoscan: progress: %zu frames processed, %zu read, %zu dropped, %lf s",
                          &processed, &read, &dropped, &elapsed),
              4)
        << line;
    EXPECT_GT(processed, last);
    EXPECT_GE(read, processed);
    EXPECT_EQ(dropped, 0u);  // not --realtime: nothing is dropped
    last = processed;
    ++lines;
  }
  // Every frame but possibly the first comes after the period has passed.
  EXPECT_GE(lines, 5u);
  EXPECT_EQ(last, 6u);
}

}  // namespace
