/// @file outputs_cli_test.cpp
/// @brief The edges of a run where work could be lost: stop signals (one, two, three, SIGHUP),
/// waits that must wake for a stop, outputs written atomically and one by one, unwritable and
/// reused output folders.
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace fs = std::filesystem;

namespace {

using aoscan::testing::AoscanProcess;
using aoscan::testing::CliRun;
using aoscan::testing::quote;
using aoscan::testing::read_stats;
using aoscan::testing::read_text;
using aoscan::testing::run_aoscan;

/// A synthetic stream far longer than any test: it ends only when stopped.
const std::string kEndless =
    "'synth:corner?frames=100000&width=160&height=120' --headless";

/// Waits until `run` has created `out` and fused for a moment (at most 30 s); false if it ended.
bool wait_until_running(AoscanProcess& run, const fs::path& out) {
  for (int i = 0; i < 300 && !fs::exists(out); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  return !run.poll();
}

/// Signals `signo` to `run` `times` times, 300 ms apart (signals sent closer may merge into one).
void signal_times(AoscanProcess& run, int signo, int times) {
  for (int i = 0; i < times; ++i) {
    if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(run.pid(), signo);
  }
}

/// The checks every stopped replay of a recording must pass: exit 0, every output written and
/// vouched for by stats.json, status "interrupted".
void expect_interrupted_and_complete(AoscanProcess& run, const fs::path& out) {
  const std::optional<int> code = run.wait_for(std::chrono::seconds(120));
  ASSERT_TRUE(code) << "no exit after the signal";
  EXPECT_EQ(*code, 0) << run.output().err;
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["status"], "interrupted");
  EXPECT_EQ(stats["stopped_by"], "signal");
  EXPECT_TRUE(stats["error"].is_null());
  EXPECT_GT(stats["frames_processed"].get<int>(), 0);
  for (const char* file : {"trajectory.txt", "mesh.ply"}) {
    ASSERT_TRUE(stats["files"].contains(file)) << file;
    EXPECT_EQ(stats["files"][file]["bytes"].get<std::uintmax_t>(), fs::file_size(out / file));
  }
  EXPECT_TRUE(stats["failed_outputs"].empty());
}

TEST(CliOutputs, SighupStopsAndWritesTheOutputs) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("sighup");
  const fs::path out = dir / "out";
  AoscanProcess run("replay " + kEndless + " --out " + quote(out.string()), dir);
  ASSERT_TRUE(run.started());
  ASSERT_TRUE(wait_until_running(run, out)) << run.output().err;
  kill(run.pid(), SIGHUP);
  expect_interrupted_and_complete(run, out);
}

TEST(CliOutputs, SecondSignalStillWritesTheOutputs) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("twice");
  const fs::path out = dir / "out";
  AoscanProcess run("replay " + kEndless + " --out " + quote(out.string()), dir);
  ASSERT_TRUE(run.started());
  ASSERT_TRUE(wait_until_running(run, out)) << run.output().err;
  kill(run.pid(), SIGINT);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  kill(run.pid(), SIGTERM);
  expect_interrupted_and_complete(run, out);
  const std::string err = run.output().err;
  // Whether the second came before or during the export, it says that the outputs are finished.
  EXPECT_NE(err.find("aoscan: SIGTERM: finishing the outputs"), std::string::npos) << err;
}

TEST(CliOutputs, ThirdSignalAbandonsTheOutputsAndSaysWhich) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("thrice");
  const fs::path out = dir / "out";
  // A fine volume over a deep view: finishing the frames in flight and the export take long
  // enough for three signals 300 ms apart.
  AoscanProcess run("replay 'synth:room?frames=100000' --headless --set fusion.voxel_size_m=0.004 "
                    "--set fusion.truncation_m=0.012 --save-volume --out " + quote(out.string()),
                    dir);
  ASSERT_TRUE(run.started());
  ASSERT_TRUE(wait_until_running(run, out)) << run.output().err;
  signal_times(run, SIGINT, 3);
  const std::optional<int> code = run.wait_for(std::chrono::seconds(60));
  ASSERT_TRUE(code) << "no exit after three signals";
  const std::string err = run.output().err;
  ASSERT_EQ(*code, 1) << "the run finished before the third signal; make it slower: " << err;
  EXPECT_NE(err.find("aoscan: error: SIGINT: outputs abandoned: "), std::string::npos) << err;
  // stats.json is written last, so an abandoned run has none: nothing vouches for partial files.
  EXPECT_FALSE(fs::exists(out / "stats.json"));
}

/// A three-frame recording whose last frame comes 1e6 s after the others.
fs::path gap_recording(const fs::path& dir) {
  const fs::path rec = aoscan::testing::record_corner(dir, 3, 160, 120);
  aoscan::testing::set_timestamps(rec, {"0.000000", "0.033333", "1000000.000000"});
  return rec;
}

TEST(CliOutputs, RealtimeGapDoesNotDelayAStop) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("gap");
  const fs::path rec = gap_recording(dir);
  const fs::path out = dir / "out";
  AoscanProcess run("replay " + quote(rec.string()) + " --realtime --headless --out " +
                        quote(out.string()),
                    dir);
  ASSERT_TRUE(run.started());
  ASSERT_TRUE(wait_until_running(run, out)) << run.output().err;
  const auto signalled = std::chrono::steady_clock::now();
  kill(run.pid(), SIGINT);
  const std::optional<int> code = run.wait_for(std::chrono::seconds(30));
  ASSERT_TRUE(code) << "the replay waited out the gap instead of stopping";
  EXPECT_EQ(*code, 0) << run.output().err;
  // The pacing wakes within 50 ms; the rest is finishing two small frames and the export.
  EXPECT_LT(std::chrono::steady_clock::now() - signalled, std::chrono::seconds(10));
  EXPECT_EQ(read_stats(out)["status"], "interrupted");
}

TEST(CliOutputs, UnwritableOutIsAUsageErrorBeforeTheRun) {
  if (!fs::is_directory("/proc/1")) GTEST_SKIP() << "no /proc/1 to stand for an unwritable folder";
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("readonly");
  // An existing folder nobody can write in (root included), and a folder under a plain file.
  std::ofstream(dir / "plain") << "x";
  for (const std::string& out : {std::string("/proc/1"), (dir / "plain" / "sub").string()}) {
    const CliRun replay =
        run_aoscan("replay 'synth:corner?frames=100000' --headless --out " + quote(out), dir);
    EXPECT_EQ(replay.exit_code, 2) << replay.err;
    EXPECT_NE(replay.err.find("aoscan: error: --out " + out + ": cannot"), std::string::npos)
        << replay.err;
    // record treats its DIR the same way.
    const CliRun record = run_aoscan("record 'synth:corner?frames=5' " + quote(out), dir);
    EXPECT_EQ(record.exit_code, 2) << record.err;
    EXPECT_NE(record.err.find("aoscan: error: "), std::string::npos) << record.err;
  }
}

TEST(CliOutputs, FailedOutputLeavesTheOthersAndSaysWhich) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("full");
  const fs::path out = dir / "out";
  const std::string args =
      "replay 'synth:corner?frames=20&width=160&height=120' --headless --out " +
      quote(out.string());
  const CliRun first = run_aoscan(args, dir);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const std::string earlier_mesh = read_text(out / "mesh.ply");
  // A file size limit of 64 KiB stands for a full disk: trajectory.txt and stats.json fit, the
  // mesh does not.
  const CliRun r = run_aoscan(args, dir, "sh -c 'ulimit -f 128; exec \"$0\" \"$@\"'");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("aoscan: error: " + (out / "mesh.ply").string() + ": cannot write"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out / "mesh.ply"));
  EXPECT_FALSE(fs::exists(out / "mesh.ply.partial"));
  EXPECT_TRUE(fs::exists(out / "trajectory.txt"));
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["status"], "failed");
  EXPECT_TRUE(stats["files"].contains("trajectory.txt"));
  EXPECT_FALSE(stats["files"].contains("mesh.ply"));
  EXPECT_TRUE(stats["failed_outputs"].contains("mesh.ply"));
  // The earlier run's good mesh is kept, moved aside, never replaced by a truncated one.
  EXPECT_EQ(read_text(out / "previous" / "mesh.ply"), earlier_mesh);
}

TEST(CliOutputs, EarlierRunsFilesAreMovedAsideAndSaid) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("rerun");
  const fs::path out = dir / "out";
  const std::string args =
      "replay 'synth:corner?frames=10&width=160&height=120' --headless --out " +
      quote(out.string());
  ASSERT_EQ(run_aoscan(args + " --save-volume", dir).exit_code, 0);
  std::ofstream(out / "mesh.ply.partial") << "left by a killed run";
  const CliRun r = run_aoscan(args, dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("holds an earlier run's"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("volume.vdb"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out / "volume.vdb"));  // not this run's: not left beside its files
  EXPECT_FALSE(fs::exists(out / "mesh.ply.partial"));
  for (const char* moved : {"volume.vdb", "mesh.ply", "stats.json", "mesh.ply.partial"})
    EXPECT_TRUE(fs::exists(out / "previous" / moved)) << moved;
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["status"], "complete");
  EXPECT_FALSE(stats["files"].contains("volume.vdb"));
}

// --points: points.ply beside mesh.ply, the same vertices (bytes) without faces, vouched for by
// stats.json; without --points none is written.
TEST(CliOutputs, PointsWritesTheSurfaceAsAPointCloud) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("points");
  const fs::path out = dir / "out";
  const CliRun r = run_aoscan("replay 'synth:corner?frames=10&width=160&height=120&colour=on' "
                              "--headless --points --out " + quote(out.string()),
                              dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string mesh = read_text(out / "mesh.ply");
  const std::string points = read_text(out / "points.ply");
  const std::size_t mesh_data = mesh.find("end_header\n") + 11;
  const std::size_t points_data = points.find("end_header\n") + 11;
  ASSERT_NE(points.find("end_header\n"), std::string::npos);
  EXPECT_EQ(points.substr(0, points_data).find("element face"), std::string::npos);
  const nlohmann::json stats = read_stats(out);
  const std::size_t vertices = stats["mesh"]["vertices"].get<std::size_t>();
  ASSERT_GT(vertices, 1000u);
  ASSERT_EQ(points.size() - points_data, vertices * (7 * 4 + 3));
  EXPECT_EQ(points.substr(points_data), mesh.substr(mesh_data, vertices * (7 * 4 + 3)));
  EXPECT_TRUE(stats["files"].contains("points.ply"));
  EXPECT_EQ(stats["mesh"]["coloured"], true);

  const fs::path plain = dir / "plain";
  ASSERT_EQ(run_aoscan("replay 'synth:corner?frames=4&width=160&height=120' --headless --out " +
                           quote(plain.string()),
                       dir)
                .exit_code,
            0);
  EXPECT_FALSE(fs::exists(plain / "points.ply"));
}

}  // namespace
