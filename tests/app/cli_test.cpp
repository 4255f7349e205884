// End-to-end tests of the aoscan executable: exit codes, one-line errors, outputs, signals.
#include <png.h>
#include <signal.h>

#include <chrono>
#include <cstdlib>
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

/// The error is exactly one line, the last on stderr, starting with "aoscan: error:" and
/// mentioning `needle` (warnings about skipped frames may come before it).
void expect_one_line_error(const CliRun& r, const std::string& needle) {
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.back(), '\n') << r.err;
  const std::size_t start = r.err.rfind('\n', r.err.size() - 2);
  const std::string last = r.err.substr(start == std::string::npos ? 0 : start + 1);
  EXPECT_EQ(last.rfind("aoscan: error: ", 0), 0u) << r.err;
  std::size_t errors = 0;
  for (std::size_t at = r.err.find("aoscan: error:"); at != std::string::npos;
       at = r.err.find("aoscan: error:", at + 1))
    ++errors;
  EXPECT_EQ(errors, 1u) << r.err;
  EXPECT_NE(last.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
}

/// A small synthetic recording in dir/rec (64x48 keeps it fast).
fs::path make_recording(const fs::path& dir, int frames = 8) {
  return aoscan::testing::record_corner(dir, frames);
}

void write_png(const fs::path& path, int width, int height, png_uint_32 format) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = format;
  std::vector<unsigned char> pixels(PNG_IMAGE_SIZE(image), 100);
  ASSERT_NE(png_image_write_to_file(&image, path.c_str(), 0, pixels.data(), 0, nullptr), 0);
}

TEST(Cli, VersionAndHelp) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("version");
  const CliRun v = run_aoscan("--version", dir);
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_NE(v.out.find("aoscan "), std::string::npos);
  const CliRun h = run_aoscan("--help", dir);
  EXPECT_EQ(h.exit_code, 0);
  for (const char* sub : {"replay", "scan", "record", "devices"})
    EXPECT_NE(h.out.find(sub), std::string::npos) << sub;
  EXPECT_EQ(run_aoscan("replay --help", dir).exit_code, 0);
}

TEST(Cli, UsageErrorsExitTwo) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("usage");
  expect_one_line_error(run_aoscan("", dir), "subcommand");
  EXPECT_EQ(run_aoscan("", dir).exit_code, 2);
  EXPECT_EQ(run_aoscan("replay", dir).exit_code, 2);
  EXPECT_EQ(run_aoscan("replay x --frames abc", dir).exit_code, 2);
  const CliRun bad_key = run_aoscan("replay synth:corner --set ao.colour=red", dir);
  EXPECT_EQ(bad_key.exit_code, 2);
  expect_one_line_error(bad_key, "ao.colour");
  const CliRun bad_value = run_aoscan("replay synth:corner --set ao.radius_m=-1", dir);
  EXPECT_EQ(bad_value.exit_code, 2);
  expect_one_line_error(bad_value, "ao.radius_m");
  std::ofstream(dir / "bad.yaml") << "ao: [1, 2\n";
  const CliRun bad_file =
      run_aoscan("replay synth:corner --config " + (dir / "bad.yaml").string(), dir);
  EXPECT_EQ(bad_file.exit_code, 2);
  expect_one_line_error(bad_file, "bad.yaml");
}

TEST(Cli, UnknownSynthSceneOrParameterExitTwo) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("synth_bad");
  const CliRun scene = run_aoscan("replay synth:castle --out " + quote((dir / "o").string()), dir);
  EXPECT_EQ(scene.exit_code, 2);
  expect_one_line_error(scene, "castle");
  const CliRun param = run_aoscan("replay " + quote("synth:corner?fraems=3"), dir);
  EXPECT_EQ(param.exit_code, 2);
  expect_one_line_error(param, "fraems");
  const CliRun value = run_aoscan("replay " + quote("synth:corner?noise=loud"), dir);
  EXPECT_EQ(value.exit_code, 2);
  expect_one_line_error(value, "noise");
}

TEST(Cli, MissingFolderAndListExitThree) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("missing");
  const CliRun missing = run_aoscan("replay " + quote((dir / "nope").string()), dir);
  EXPECT_EQ(missing.exit_code, 3);
  expect_one_line_error(missing, (dir / "nope").string());

  fs::create_directories(dir / "empty");
  const CliRun no_list = run_aoscan("replay " + quote((dir / "empty").string()), dir);
  EXPECT_EQ(no_list.exit_code, 3);
  expect_one_line_error(no_list, "depth.txt");

  const fs::path rec = make_recording(dir);
  std::ofstream(rec / "depth.txt", std::ios::app) << "this line is garbled\n";
  const CliRun garbled = run_aoscan("replay " + quote(rec.string()), dir);
  EXPECT_EQ(garbled.exit_code, 3);
  expect_one_line_error(garbled, "depth.txt:");
}

TEST(Cli, BadCameraJsonExitsThree) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("camera");
  const fs::path rec = make_recording(dir);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"missing", R"({"fx": 52.5, "fy": 52.5, "cx": 31.5, "depth_scale": 5000})"},
      {"negative", R"({"fx": -52.5, "fy": 52.5, "cx": 31.5, "cy": 23.5, "depth_scale": 5000})"},
      {"nan", R"({"fx": NaN, "fy": 52.5, "cx": 31.5, "cy": 23.5, "depth_scale": 5000})"},
      {"string", R"({"fx": "a", "fy": 52.5, "cx": 31.5, "cy": 23.5, "depth_scale": 5000})"},
  };
  for (const auto& [name, text] : cases) {
    std::ofstream(rec / "camera.json", std::ios::trunc) << text;
    const CliRun r = run_aoscan(
        "replay " + quote(rec.string()) + " --out " + quote((dir / ("o_" + name)).string()), dir);
    EXPECT_EQ(r.exit_code, 3) << name << ": " << r.err;
    expect_one_line_error(r, "camera.json");
  }
}

TEST(Cli, BadFramesAreCountedSkipsOrStrictErrors) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("frames");
  const fs::path rec = make_recording(dir, 10);
  // Frame files are named by sequence: break five of the ten in five different ways.
  std::vector<fs::path> pngs;
  for (const auto& e : fs::directory_iterator(rec / "depth")) pngs.push_back(e.path());
  std::sort(pngs.begin(), pngs.end());
  ASSERT_EQ(pngs.size(), 10u);
  fs::remove(pngs[1]);                                   // listed but missing
  fs::resize_file(pngs[3], fs::file_size(pngs[3]) / 2);  // truncated
  write_png(pngs[5], 64, 48, PNG_FORMAT_GRAY);           // 8-bit
  write_png(pngs[6], 64, 48, PNG_FORMAT_RGB);            // colour
  write_png(pngs[8], 32, 24, PNG_FORMAT_LINEAR_Y);       // 16-bit but another size
  const fs::path out = dir / "out";
  const CliRun r =
      run_aoscan("replay " + quote(rec.string()) + " --headless --out " + quote(out.string()), dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["frames_corrupt"], 5);
  EXPECT_EQ(stats["frames_processed"], 5);

  const CliRun strict = run_aoscan("replay " + quote(rec.string()) + " --headless --strict --out " +
                                       quote((dir / "o2").string()),
                                   dir);
  EXPECT_EQ(strict.exit_code, 3);
  expect_one_line_error(strict, pngs[1].filename().string());
  EXPECT_NE(strict.err.find("frame 1"), std::string::npos) << strict.err;
}

TEST(Cli, NoUsableFrameExitsThree) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("nousable");
  const fs::path rec = make_recording(dir, 3);
  for (const auto& e : fs::directory_iterator(rec / "depth")) fs::resize_file(e.path(), 10);
  const CliRun r = run_aoscan(
      "replay " + quote(rec.string()) + " --headless --out " + quote((dir / "o").string()), dir);
  EXPECT_EQ(r.exit_code, 3);
  expect_one_line_error(r, "no usable frame");
}

TEST(Cli, RecordThenReplaySynthetic) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("record");
  const fs::path rec = dir / "D";
  const CliRun rec_r =
      run_aoscan("record " + quote("synth:corner?frames=60&noise=kinect&width=160&height=120") +
                     " " + quote(rec.string()),
                 dir);
  ASSERT_EQ(rec_r.exit_code, 0) << rec_r.err;
  for (const char* f : {"depth.txt", "camera.json", "groundtruth.txt", "scene.ply"})
    EXPECT_TRUE(fs::exists(rec / f)) << f;
  const fs::path out = dir / "O";
  const CliRun r =
      run_aoscan("replay " + quote(rec.string()) + " --headless --out " + quote(out.string()), dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["frames_processed"], 60);
  EXPECT_EQ(stats["frames_read"], 60);
  for (const char* key : {"frames_dropped", "frames_corrupt", "frames_tracking_lost", "wall_s",
                          "fps", "export_s", "threads", "peak_rss_mb", "stages"})
    EXPECT_TRUE(stats.contains(key)) << key;
  for (const auto& [name, stage] : stats["stages"].items())
    for (const char* key : {"ms_mean", "ms_p50", "ms_p95", "ms_max"})
      EXPECT_TRUE(stage.contains(key)) << name << "." << key;
  EXPECT_TRUE(stats["stages"].contains("preprocess"));

  // A second recording of the same spec is byte-identical (deterministic synthesis).
  const fs::path rec2 = dir / "D2";
  ASSERT_EQ(
      run_aoscan("record " + quote("synth:corner?frames=60&noise=kinect&width=160&height=120") +
                     " " + quote(rec2.string()),
                 dir)
          .exit_code,
      0);
  for (const char* f : {"depth.txt", "groundtruth.txt", "depth/000059.png"})
    EXPECT_EQ(read_text(rec / f), read_text(rec2 / f)) << f;
  // Recording refuses to overwrite an existing recording.
  EXPECT_EQ(run_aoscan("record synth:corner " + quote(rec.string()), dir).exit_code, 2);
}

TEST(Cli, SigintWritesOutputsAndExitsZero) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("sigint");
  const fs::path out = dir / "out";
  AoscanProcess run("replay 'synth:corner?frames=100000&width=160&height=120' --headless --out " +
                        quote(out.string()),
                    dir);
  ASSERT_TRUE(run.started());
  // Signal once the run is under way (stats of a run that processed frames), at most 30 s on.
  for (int i = 0; i < 300 && !fs::exists(out); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  ASSERT_FALSE(run.poll()) << run.output().err;
  kill(run.pid(), SIGINT);
  const std::optional<int> code = run.wait_for(std::chrono::seconds(120));
  ASSERT_TRUE(code) << "no exit after SIGINT";
  EXPECT_EQ(*code, 0) << run.output().err;
  const nlohmann::json stats = read_stats(out);
  EXPECT_GT(stats["frames_processed"].get<int>(), 0);
  EXPECT_EQ(stats["frames_processed"], stats["frames_read"]);
}

TEST(Cli, ReplaysRedKitchen) {
  aoscan::testing::ScratchDir scratch;
  const fs::path data = fs::path(AOSCAN_SHARED_DATA_DIR) / "7scenes-redkitchen";
  if (!fs::exists(data / "depth.txt")) GTEST_SKIP() << "shared data not found at " << data;
  const fs::path dir = scratch.folder("redkitchen");
#ifdef AOSCAN_SANITIZED
  const int frames = 40;  // the whole recording takes minutes under the sanitizers
#else
  const int frames = 500;
#endif
  const CliRun r = run_aoscan("replay " + quote(data.string()) + " --headless --frames " +
                                  std::to_string(frames) + " --out " + quote((dir / "o").string()),
                              dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json stats = read_stats(dir / "o");
  EXPECT_EQ(stats["frames_processed"], frames);
  EXPECT_EQ(stats["frames_tracking_lost"], 0);
  EXPECT_EQ(stats["frames_corrupt"], 0);
}

}  // namespace

namespace {

TEST(Readme, DocumentsEveryConfigurationKey) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("readme");
  const CliRun config = run_aoscan("config", dir);
  ASSERT_EQ(config.exit_code, 0);
  const std::string readme = read_text(fs::path(AOSCAN_SOURCE_DIR) / "README.md");
  std::istringstream lines(config.out);
  std::string line, section;
  int keys = 0;
  while (std::getline(lines, line)) {
    if (line.empty()) continue;
    if (line[0] != ' ') {
      section = line.substr(0, line.find(':'));
      continue;
    }
    const std::string key = section + "." + line.substr(2, line.find(':') - 2);
    EXPECT_NE(readme.find("`" + key + "`"), std::string::npos) << key << " is not in README.md";
    ++keys;
  }
  EXPECT_GT(keys, 10);
}

}  // namespace

namespace {

TEST(Cli, ReplayIsDeterministicForTheSameThreads) {
#if defined(AOSCAN_SANITIZED)
  GTEST_SKIP() << "two 60-frame replays compared byte for byte; the Release suite checks this, and "
                  "the sanitizers see the same code in the shorter replays of this suite";
#endif
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("determinism");
  const std::string source = quote(std::string(AOSCAN_SOURCE_DIR) + "/recordings/corner");
  for (const char* run : {"a", "b"}) {
    const CliRun r = run_aoscan("replay " + source + " --headless --threads 2 --frames 60 --out " +
                                    quote((dir / run).string()),
                                dir);
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  for (const char* file : {"trajectory.txt", "mesh.ply"}) {
    const std::string a = read_text(dir / "a" / file);
    EXPECT_FALSE(a.empty()) << file;
    EXPECT_EQ(a, read_text(dir / "b" / file)) << file << " differs between two identical replays";
  }
  const nlohmann::json stats = read_stats(dir / "a");
  EXPECT_EQ(stats["frames_tracking_lost"], 0);
  EXPECT_GT(stats["mesh"]["faces"].get<int>(), 1000);
  // The MVAO grid's cells sit in bricks of 4^3 (768 bytes each): a surface fills part of each.
  const auto cells = stats["mvao_grid"]["cells"].get<std::size_t>();
  const auto bricks = stats["mvao_grid"]["bricks"].get<std::size_t>();
  EXPECT_GT(bricks, 100u);
  EXPECT_GT(cells, 4 * bricks);
  EXPECT_LE(cells, 64 * bricks);
  EXPECT_GE(stats["mvao_grid"]["memory_mb"].get<double>(), bricks * 768.0 / (1024.0 * 1024.0));
}

}  // namespace
