// End-to-end camera runs of the aoscan executable under fakenect: scan until the dump ends
// (unplug → exit 4 with outputs written), record from the live Kinect path, devices, no camera.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace fs = std::filesystem;

namespace {

using aoscan::testing::CliRun;
using aoscan::testing::read_text;

/// Runs `env aoscan args` (stdout and stderr kept in `scratch`).
CliRun run(const std::string& env, const std::string& args, const fs::path& scratch) {
  return aoscan::testing::run_aoscan(args, scratch, env);
}

/// Environment that makes aoscan's libfreenect the fakenect replay of `dump`.
std::string fakenect_env(const fs::path& dump) {
  return "LD_LIBRARY_PATH='" AOSCAN_FAKENECT_DIR "' FAKENECT_PATH='" + dump.string() + "'";
}

/// A fakenect dump of `frames` synthetic frames; empty path when fakenect is not installed.
fs::path make_dump(const fs::path& dir, int frames) {
  if (!fs::exists(fs::path(AOSCAN_FAKENECT_DIR) / "libfreenect.so")) return {};
  const fs::path rec = dir / "rec";
  const fs::path dump = dir / "dump";
  CliRun r =
      run("", "record 'synth:corner?frames=" + std::to_string(frames) + "' '" + rec.string() + "'",
          dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const fs::path tool = fs::path(AOSCAN_BINARY).parent_path() / "aoscan-fakenect-dump";
  if (!fs::exists(tool)) return {};
  const std::string cmd =
      "'" + tool.string() + "' '" + rec.string() + "' '" + dump.string() + "' 2>/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  return dump;
}

TEST(CameraCli, ScanUntilTheKinectIsUnpluggedWritesOutputsAndExitsFour) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("scan");
  const fs::path dump = make_dump(dir, 10);
  if (dump.empty()) GTEST_SKIP() << "fakenect or aoscan-fakenect-dump not available";
  const CliRun r =
      run(fakenect_env(dump),
          "scan --device freenect --headless --out '" + (dir / "out").string() + "'", dir);
  EXPECT_EQ(r.exit_code, 4) << r.err;
  EXPECT_NE(r.err.find("aoscan: error: freenect"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("unplugged"), std::string::npos) << r.err;
  const auto stats = nlohmann::json::parse(read_text(dir / "out" / "stats.json"));
  EXPECT_EQ(stats["frames_read"].get<int>(), 10);
  EXPECT_EQ(stats["frames_processed"].get<int>() + stats["frames_dropped"].get<int>(), 10);
  // The latency is counted from libfreenect's callback (not from the clock's epoch or the start
  // of the run): positive, and below the 1 s bound even on a loaded machine.
  const auto& latency = stats["capture_latency_ms"];
  EXPECT_GT(latency["p50"].get<double>(), 0.0);
  EXPECT_LE(latency["p50"].get<double>(), latency["max"].get<double>());
  EXPECT_LT(latency["max"].get<double>(), 1000.0);
  EXPECT_GE(stats["capture_cpu_percent"].get<double>(), 0.0);
  EXPECT_LE(stats["capture_cpu_percent"].get<double>(), 100.0);
}

TEST(CameraCli, DevicesListsTheKinectAndAutoScansIt) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("devices");
  const fs::path dump = make_dump(dir, 4);
  if (dump.empty()) GTEST_SKIP() << "fakenect or aoscan-fakenect-dump not available";
  const CliRun d = run(fakenect_env(dump), "devices", dir);
  EXPECT_EQ(d.exit_code, 0) << d.err;
  EXPECT_NE(d.out.find("freenect:0\t"), std::string::npos) << d.out;
  const CliRun s =
      run(fakenect_env(dump), "scan --headless --out '" + (dir / "out").string() + "'", dir);
  EXPECT_EQ(s.exit_code, 4) << s.err;  // auto picked the Kinect; the dump's end is the unplug
  EXPECT_TRUE(fs::exists(dir / "out" / "stats.json"));
}

TEST(CameraCli, RecordFromTheLiveKinectKeepsEveryFrameUntilTheUnplug) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("record");
  const fs::path dump = make_dump(dir, 12);
  if (dump.empty()) GTEST_SKIP() << "fakenect or aoscan-fakenect-dump not available";
  const fs::path out = dir / "kinect";
  const CliRun r = run(fakenect_env(dump), "record freenect '" + out.string() + "'", dir);
  EXPECT_EQ(r.exit_code, 4) << r.err;
  std::ifstream list(out / "depth.txt");
  int frames = 0;
  for (std::string line; std::getline(list, line);)
    if (!line.empty() && line[0] != '#') ++frames;
  EXPECT_EQ(frames, 12);
  EXPECT_TRUE(fs::exists(out / "camera.json"));
  // What was kept is said before the error that ended it.
  EXPECT_NE(r.err.find("recorded 12 frames to"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("stopped delivering frames"), std::string::npos) << r.err;
  const CliRun limited =
      run(fakenect_env(dump), "record freenect '" + (dir / "five").string() + "' --frames 5", dir);
  EXPECT_EQ(limited.exit_code, 0) << limited.err;
}

TEST(CameraCli, NoCameraAndNonCameraNodesAreExitFourWithOneLine) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("none");
  const CliRun v =
      run("", "scan --headless --device v4l2:/dev/null --out '" + (dir / "o").string() + "'", dir);
  EXPECT_EQ(v.exit_code, 4);
  EXPECT_NE(v.err.find("aoscan: error: v4l2:/dev/null: not a V4L2 device"), std::string::npos)
      << v.err;
  const CliRun k =
      run("", "scan --headless --device freenect:5 --out '" + (dir / "o").string() + "'", dir);
  EXPECT_EQ(k.exit_code, 4);
  EXPECT_NE(k.err.find("freenect:5"), std::string::npos) << k.err;
}

}  // namespace
