/// @file messages_cli_test.cpp
/// @brief Honest results and messages: a run that fused nothing fails with the reason, repeated
/// timestamps are counted, the calibration's origin is said, options name their ranges in plain
/// numbers, and each error names what is really wrong.
#include <png.h>

#include <algorithm>
#include <cstdint>
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

using aoscan::testing::CliRun;
using aoscan::testing::count;
using aoscan::testing::quote;
using aoscan::testing::read_stats;
using aoscan::testing::read_text;
using aoscan::testing::run_aoscan;
using aoscan::testing::set_timestamps;

/// The last line of stderr, which must be the run's one error line.
std::string error_line(const CliRun& r) {
  EXPECT_EQ(count(r.err, "aoscan: error: "), 1u) << r.err;
  const std::size_t at = r.err.find("aoscan: error: ");
  return at == std::string::npos ? "" : r.err.substr(at, r.err.find('\n', at) - at);
}

/// A recording of `frames` frames of the synthetic corner (64 x 48) in dir/rec.
fs::path make_recording(const fs::path& dir, int frames = 6) {
  return aoscan::testing::record_corner(dir, frames);
}

/// The PNGs of a recording, in order.
std::vector<fs::path> frame_files(const fs::path& rec) {
  std::vector<fs::path> pngs;
  for (const auto& e : fs::directory_iterator(rec / "depth")) pngs.push_back(e.path());
  std::sort(pngs.begin(), pngs.end());
  return pngs;
}

/// Overwrites `path` with a 64 x 48 16-bit PNG whose every raw depth is `value`.
void write_constant_png(const fs::path& path, std::uint16_t value) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = 64;
  image.height = 48;
  image.format = PNG_FORMAT_LINEAR_Y;
  const std::vector<std::uint16_t> pixels(64 * 48, value);
  ASSERT_TRUE(png_image_write_to_file(&image, path.c_str(), 0, pixels.data(), 0, nullptr));
}

TEST(CliMessages, RunThatFusedNothingExitsThreeWithTheReason) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("nothing");
  // All 0 (invalid), all 65535 (invalid): frames are read, but nothing has depth.
  for (const std::uint16_t value : {std::uint16_t{0}, std::uint16_t{65535}}) {
    const fs::path rec = make_recording(dir);
    for (const fs::path& png : frame_files(rec)) write_constant_png(png, value);
    const fs::path out = dir / ("out" + std::to_string(value));
    const CliRun r = run_aoscan("replay " + quote(rec.string()) + " --headless --out " +
                                    quote(out.string()),
                                dir);
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_NE(error_line(r).find("nothing was fused from 6 frames: no frame has valid depth"),
              std::string::npos)
        << r.err;
    const nlohmann::json stats = read_stats(out);
    EXPECT_EQ(stats["status"], "failed");
    EXPECT_EQ(stats["frames_without_depth"], 6);
    fs::remove_all(rec);
  }
  // A depth scale that puts every point 1000 times farther than recorded: beyond the range.
  const fs::path rec = make_recording(dir);
  std::ofstream(rec / "camera.json")
      << R"({"fx": 52.5, "fy": 52.5, "cx": 31.5, "cy": 23.5, "depth_scale": 5})";
  const CliRun far = run_aoscan(
      "replay " + quote(rec.string()) + " --headless --out " + quote((dir / "far").string()), dir);
  EXPECT_EQ(far.exit_code, 3) << far.err;
  EXPECT_NE(error_line(far).find("no frame has valid depth"), std::string::npos) << far.err;
}

TEST(CliMessages, ImpossibleCalibrationIsRefusedNamingTheValue) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("impossible");
  const fs::path rec = make_recording(dir);
  // A principal point far outside the image sent every raycast ray kilometres sideways: minutes
  // per frame for nothing. Refused at once, naming the file and the value.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"fx": 52.5, "fy": 52.5, "cx": 100000, "cy": 23.5, "depth_scale": 5000})", "cx 100000"},
      {R"({"fx": 0.001, "fy": 52.5, "cx": 31.5, "cy": 23.5, "depth_scale": 5000})", "fx 0.001"}};
  for (const auto& [json, needle] : cases) {
    std::ofstream(rec / "camera.json") << json;
    const CliRun r = run_aoscan(
        "replay " + quote(rec.string()) + " --headless --out " + quote((dir / "o").string()), dir);
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_NE(error_line(r).find((rec / "camera.json").string() + ": " + needle),
              std::string::npos)
        << r.err;
  }
}

/// make_recording() whose third frame repeats the second's timestamp and whose fourth goes back.
fs::path make_recording_out_of_order(const fs::path& dir) {
  const fs::path rec = make_recording(dir);
  set_timestamps(rec, {"1.0", "1.1", "1.1", "1.05", "1.2", "1.3"});
  return rec;
}

TEST(CliMessages, RepeatedOrBackwardTimestampsAreCountedAndDropped) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("stamps");
  const fs::path rec = make_recording_out_of_order(dir);
  const fs::path out = dir / "out";
  const CliRun r = run_aoscan(
      "replay " + quote(rec.string()) + " --headless --out " + quote(out.string()), dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("timestamp 1.100000 does not follow 1.100000"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("2 frames dropped: their timestamps repeat or go back"), std::string::npos)
      << r.err;
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["frames_out_of_order"], 2);
  EXPECT_EQ(stats["frames_processed"], 4);
  // trajectory.txt keeps strictly increasing timestamps.
  std::istringstream trajectory(read_text(out / "trajectory.txt"));
  std::vector<double> stamps;
  for (std::string line; std::getline(trajectory, line);)
    if (!line.empty() && line[0] != '#') stamps.push_back(std::stod(line));
  ASSERT_GE(stamps.size(), 2u);
  EXPECT_TRUE(std::is_sorted(stamps.begin(), stamps.end()));
  EXPECT_EQ(std::adjacent_find(stamps.begin(), stamps.end()), stamps.end());
  // --strict: an error naming the frame.
  const CliRun strict = run_aoscan("replay " + quote(rec.string()) + " --headless --strict --out " +
                                       quote((dir / "strict").string()),
                                   dir);
  EXPECT_EQ(strict.exit_code, 3) << strict.err;
  EXPECT_NE(error_line(strict).find("(frame 2): timestamp"), std::string::npos) << strict.err;
}

TEST(CliMessages, RecordingARecordingDropsRepeatedOrBackwardTimestampsAsAReplayDoes) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("record_stamps");
  const fs::path rec = make_recording_out_of_order(dir);
  const fs::path copy = dir / "copy";
  const CliRun r = run_aoscan("record " + quote(rec.string()) + " " + quote(copy.string()), dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("(frame 2): timestamp 1.100000 does not follow 1.100000"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("recorded 4 frames"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("2 frames dropped: their timestamps repeat or go back"), std::string::npos)
      << r.err;
  // The copy's depth.txt lists the four frames in increasing time, each with its image.
  std::istringstream list(read_text(copy / "depth.txt"));
  std::vector<double> stamps;
  for (std::string line; std::getline(list, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t = 0;
    std::string name;
    fields >> t >> name;
    stamps.push_back(t);
    EXPECT_TRUE(fs::is_regular_file(copy / name)) << name;
  }
  EXPECT_EQ(stamps, (std::vector<double>{1.0, 1.1, 1.2, 1.3}));
  // Replaying the copy drops nothing.
  const fs::path out = dir / "out";
  const CliRun replay = run_aoscan(
      "replay " + quote(copy.string()) + " --headless --out " + quote(out.string()), dir);
  EXPECT_EQ(replay.exit_code, 0) << replay.err;
  EXPECT_EQ(read_stats(out)["frames_out_of_order"], 0);
  EXPECT_EQ(read_stats(out)["frames_processed"], 4);
}

TEST(CliMessages, CalibrationAndItsOriginAreLoggedAndRecorded) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("calibration");
  const fs::path rec = make_recording(dir);
  const CliRun own = run_aoscan(
      "replay " + quote(rec.string()) + " --headless --out " + quote((dir / "own").string()), dir);
  ASSERT_EQ(own.exit_code, 0) << own.err;
  EXPECT_EQ(own.err.find("default calibration"), std::string::npos) << own.err;
  const nlohmann::json k = read_stats(dir / "own")["calibration"];
  EXPECT_EQ(k["origin"], (rec / "camera.json").string());
  EXPECT_DOUBLE_EQ(k["fx"].get<double>(), 52.5);
  EXPECT_EQ(k["width"], 64);

  // Without camera.json the generic default is used, and the run says so.
  fs::remove(rec / "camera.json");
  const CliRun fallback = run_aoscan(
      "replay " + quote(rec.string()) + " --headless --frames 1 --out " +
          quote((dir / "default").string()),
      dir);
  EXPECT_NE(fallback.err.find("aoscan: warning: " + rec.string() +
                              ": the default calibration (no camera.json): fx 525"),
            std::string::npos)
      << fallback.err;
  const nlohmann::json d = read_stats(dir / "default")["calibration"];
  EXPECT_EQ(d["origin"], "the default calibration (no camera.json)");
  EXPECT_DOUBLE_EQ(d["depth_scale"].get<double>(), 5000.0);
}

TEST(CliMessages, OptionsNameTheirRangeInPlainNumbers) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("ranges");
  const CliRun zero = run_aoscan("replay synth:corner --frames 0", dir);
  EXPECT_EQ(zero.exit_code, 2);
  const std::string zero_line = error_line(zero);
  EXPECT_NE(zero_line.find("--frames: 0 is out of range: a whole number from 1 to 17179869184"),
            std::string::npos)
      << zero_line;
  EXPECT_LT(zero_line.size(), 160u) << zero_line;
  const CliRun huge = run_aoscan("replay synth:corner --frames 99999999999999999999999", dir);
  EXPECT_EQ(huge.exit_code, 2);
  EXPECT_NE(error_line(huge).find("is out of range"), std::string::npos) << huge.err;
  const CliRun word = run_aoscan("replay synth:corner --threads two", dir);
  EXPECT_EQ(word.exit_code, 2);
  EXPECT_NE(error_line(word).find("'two' is not a whole number from 1 to 1024"), std::string::npos)
      << word.err;
  // Configuration values: an integer too large for any int is out of range, not "not an integer".
  const CliRun samples = run_aoscan("replay synth:corner --set ao.samples=99999999999", dir);
  EXPECT_EQ(samples.exit_code, 2);
  EXPECT_NE(error_line(samples).find("ao.samples is out of range: it must be from"),
            std::string::npos)
      << samples.err;
  const CliRun radius = run_aoscan("replay synth:corner --set ao.radius_m=-1", dir);
  EXPECT_EQ(radius.exit_code, 2);
  const std::string radius_line = error_line(radius);
  EXPECT_NE(radius_line.find("ao.radius_m is out of range: it must be"), std::string::npos)
      << radius_line;
  EXPECT_EQ(radius_line.find("e+"), std::string::npos) << radius_line;
  EXPECT_EQ(radius_line.find("e-"), std::string::npos) << radius_line;
}

TEST(CliMessages, ThreadsBeyondTheMachineAreSaidAndTheUsedNumberRecorded) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("threads");
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const CliRun r = run_aoscan(
      "replay 'synth:corner?frames=3&width=64&height=48' --headless --threads 1000 --out " +
          quote((dir / "o").string()),
      dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("--threads 1000: this machine runs " + std::to_string(cores)),
            std::string::npos)
      << r.err;
  EXPECT_EQ(read_stats(dir / "o")["threads"], cores);
  EXPECT_EQ(run_aoscan("replay synth:corner --threads 100000", dir).exit_code, 2);
}

TEST(CliMessages, ErrorsNameWhatIsWrong) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("names");
  const CliRun unknown = run_aoscan("replya synth:corner", dir);
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(error_line(unknown).find("unknown subcommand 'replya'"), std::string::npos)
      << unknown.err;
  // A plain file is not "no such folder".
  std::ofstream(dir / "notes.txt") << "x";
  const CliRun file = run_aoscan("replay " + quote((dir / "notes.txt").string()), dir);
  EXPECT_EQ(file.exit_code, 3);
  EXPECT_NE(error_line(file).find("notes.txt: is a file, not a recording folder"),
            std::string::npos)
      << file.err;
  // An unknown camera name is not a folder either.
  const CliRun camera = run_aoscan("scan --headless --device kinect", dir);
  EXPECT_EQ(camera.exit_code, 2);
  EXPECT_NE(error_line(camera).find("--device kinect: unknown camera"), std::string::npos)
      << camera.err;
}

TEST(CliMessages, StrictRunCountsTheFrameThatStoppedIt) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("strict");
  const fs::path rec = make_recording(dir);
  fs::resize_file(frame_files(rec)[2], 10);
  const fs::path out = dir / "out";
  const CliRun r = run_aoscan(
      "replay " + quote(rec.string()) + " --headless --strict --out " + quote(out.string()), dir);
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_EQ(read_stats(out)["frames_corrupt"], 1);
}

TEST(CliMessages, CostlyConfigurationWarns) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("costly");
  const CliRun r = run_aoscan(
      "replay 'synth:corner?frames=2&width=64&height=48' --headless --set ao.grid_resolution=4096 "
      "--out " + quote((dir / "o").string()),
      dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("aoscan: warning: configuration: the MVAO grid's cells"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("0.0009765625 m) are finer than the TSDF's voxels"), std::string::npos)
      << r.err;
}

}  // namespace
