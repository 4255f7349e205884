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

using aoscan::testing::fakenect_env;
using aoscan::testing::make_fakenect_dump;

TEST(CameraCli, ScanUntilTheKinectIsUnpluggedWritesOutputsAndExitsFour) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("scan");
  const fs::path dump = make_fakenect_dump(dir, 10);
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
  const fs::path dump = make_fakenect_dump(dir, 4);
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
  const fs::path dump = make_fakenect_dump(dir, 12);
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

/// A camera.json with a colour camera beside the depth camera (values chosen to be exact in
/// binary and unlike every default).
/// `depth_scale`: the source's raw units per metre (1000 for a Kinect, 5000 for synth:).
fs::path write_camera(const fs::path& dir, int depth_scale = 1000) {
  const fs::path path = dir / "calibrated.json";
  std::ofstream(path) << R"({ "fx": 600.5, "fy": 601.25, "cx": 318.75, "cy": 241.5,
    "depth_scale": )" << depth_scale << R"(,
    "colour": { "width": 640, "height": 480, "fx": 530.5, "fy": 530.5, "cx": 320.25, "cy": 240.75,
                "depth_to_colour": [1, 0, 0, -0.0234375, 0, 1, 0, 0.001953125, 0, 0, 1, 0] } })";
  return path;
}

/// Checks that `json` (a recording's camera.json) is write_camera()'s camera.
void expect_written_camera(const fs::path& json, int depth_scale = 1000) {
  const auto cam = nlohmann::json::parse(read_text(json));
  EXPECT_EQ(cam["width"].get<int>(), 640);
  EXPECT_EQ(cam["fx"].get<double>(), 600.5);
  EXPECT_EQ(cam["fy"].get<double>(), 601.25);
  EXPECT_EQ(cam["cx"].get<double>(), 318.75);
  EXPECT_EQ(cam["cy"].get<double>(), 241.5);
  EXPECT_EQ(cam["depth_scale"].get<double>(), depth_scale);
  ASSERT_TRUE(cam.contains("colour")) << cam.dump();
  EXPECT_EQ(cam["colour"]["fx"].get<double>(), 530.5);
  EXPECT_EQ(cam["colour"]["cx"].get<double>(), 320.25);
  EXPECT_EQ(cam["colour"]["depth_to_colour"][3].get<double>(), -0.0234375);
  EXPECT_EQ(cam["colour"]["depth_to_colour"][7].get<double>(), 0.001953125);
}

int count_entries(const fs::path& list) {
  std::ifstream in(list);
  int n = 0;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') ++n;
  return n;
}

TEST(CameraCli, RecordWithCameraFileWritesThatCameraIntoTheRecording) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("record_camera");
  const fs::path camera = write_camera(dir, 5000);
  const fs::path out = dir / "rec";
  const CliRun r = run("", "record 'synth:corner?frames=3&colour=on' '" + out.string() +
                               "' --camera '" + camera.string() + "'",
                       dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_written_camera(out / "camera.json", 5000);
  EXPECT_EQ(count_entries(out / "rgb.txt"), 3);
  // The recording replays with that camera.
  const CliRun replay = run("", "replay '" + out.string() + "' --headless --no-progress --out '" +
                                    (dir / "out").string() + "'",
                            dir);
  EXPECT_EQ(replay.exit_code, 0) << replay.err;
  const auto stats = nlohmann::json::parse(read_text(dir / "out" / "stats.json"));
  EXPECT_EQ(stats["calibration"]["fx"].get<double>(), 600.5);
  // fusion.colour_every = 2: the colour of frames 0 and 2 is read.
  EXPECT_EQ(stats["frames_with_colour"].get<int>(), 2);
}

TEST(CameraCli, BadCameraFileIsExitTwoNamingItBeforeAnythingIsOpened) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("bad_camera");
  const fs::path bad = dir / "bad.json";
  std::ofstream(bad) << R"({ "fx": 600, "fy": 600, "cx": 320, "cy": 240 })";
  const CliRun r = run("", "record 'synth:corner?frames=2' '" + (dir / "rec").string() +
                               "' --camera '" + bad.string() + "'",
                       dir);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(r.err, "aoscan: error: --camera " + bad.string() +
                       ": missing key 'depth_scale'\n");
  EXPECT_FALSE(fs::exists(dir / "rec"));
  // scan reads it before the camera: exit 2, not the missing camera's 4.
  const fs::path missing = dir / "missing.json";
  const CliRun s = run("", "scan --headless --device freenect:5 --camera '" + missing.string() +
                               "' --out '" + (dir / "o").string() + "'",
                       dir);
  EXPECT_EQ(s.exit_code, 2) << s.err;
  EXPECT_EQ(s.err, "aoscan: error: --camera " + missing.string() + ": cannot open camera file\n");
  // A camera of another size than the source's is refused too.
  const fs::path small = dir / "small.json";
  std::ofstream(small) << R"({ "width": 320, "height": 240, "fx": 300, "fy": 300, "cx": 160,
                               "cy": 120, "depth_scale": 1000 })";
  const CliRun z = run("", "record 'synth:corner?frames=2' '" + (dir / "rec").string() +
                               "' --camera '" + small.string() + "'",
                       dir);
  EXPECT_EQ(z.exit_code, 2) << z.err;
  EXPECT_NE(z.err.find(small.string() + ": a 320x240 camera, but synth:corner?frames=2 delivers "
                                         "640x480 depth"),
            std::string::npos)
      << z.err;
}

TEST(CameraCli, KinectColourIsRecordedAndScannedWithTheCameraFile) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("kinect_colour");
  const fs::path dump = make_fakenect_dump(dir, 6, "&colour=on");
  if (dump.empty()) GTEST_SKIP() << "fakenect or aoscan-fakenect-dump not available";
  const fs::path camera = write_camera(dir);
  const fs::path out = dir / "kinect";
  const CliRun r = run(fakenect_env(dump),
                       "record freenect '" + out.string() + "' --camera '" + camera.string() + "'",
                       dir);
  EXPECT_EQ(r.exit_code, 4) << r.err;  // the dump's end is the unplug
  EXPECT_EQ(count_entries(out / "depth.txt"), 6);
  EXPECT_EQ(count_entries(out / "rgb.txt"), 6);  // every RGB frame paired with its depth
  expect_written_camera(out / "camera.json");
  // The recorded colour is the synthetic scene's, frame for frame.
  EXPECT_EQ(read_text(out / "rgb" / "000003.png"), read_text(dir / "rec" / "rgb" / "000003.png"));

  const CliRun s = run(fakenect_env(dump),
                       "scan --device freenect --headless --camera '" + camera.string() +
                           "' --out '" + (dir / "out").string() + "'",
                       dir);
  EXPECT_EQ(s.exit_code, 4) << s.err;
  const auto stats = nlohmann::json::parse(read_text(dir / "out" / "stats.json"));
  EXPECT_EQ(stats["frames_read"].get<int>(), 6);
  EXPECT_EQ(stats["frames_colour_skipped"].get<int>(), 0);
  EXPECT_EQ(stats["calibration"]["fx"].get<double>(), 600.5);
  EXPECT_NE(stats["calibration"]["origin"].get<std::string>().find(camera.string()),
            std::string::npos);
  EXPECT_NE(stats["calibration"]["colour_origin"].get<std::string>().find(camera.string()),
            std::string::npos);
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
