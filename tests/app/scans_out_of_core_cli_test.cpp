// End-to-end tests of the out-of-core side of `aoscan scans`: a memory limit that holds only a
// few scans at once, resuming from the scratch folder, and what goes wrong there. Each compares
// the outputs byte for byte with an unconstrained run of the same set.
#include <signal.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;
using testing::quote;
using testing::read_stats;
using testing::read_text;
using testing::run_aoscan;
using testing::ScratchDir;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;  // ASan's quarantine keeps freed memory resident
#else
constexpr bool kSanitized = false;
#endif

/// Nine 160 x 120 pinhole scans: every 5th frame of a 41-frame synthetic corner recording.
class ScansOutOfCore : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(run_aoscan("record '" + spec() + "' " + quote(rec()), dir_.str()).exit_code, 0);
  }
  virtual std::string spec() const { return "synth:corner?frames=41&width=160&height=120"; }
  std::string rec() const { return dir_.file("rec"); }
  /// Runs `scans` on the recording into `out` with `extra` options.
  testing::CliRun scans(const std::string& out, const std::string& extra) const {
    return run_aoscan("scans " + quote(rec()) + " --every 5 --neighbourhood 3 --threads 2 --out " +
                          quote(dir_.file(out)) + " " + extra,
                      dir_.str());
  }
  std::string ply(const std::string& out) const { return read_text(dir_.file(out + "/points.ply")); }
  ScratchDir dir_;
};

/// The same nine scans at 320 x 240 (2.3 MB each), so that a memory limit between what one stage
/// needs and what nine scans take lies megabytes away from both: more than the process's own
/// memory moves from one run to the next (at 160 x 120 the margin was 1 MB, and a run could miss).
class ScansOutOfCoreLarger : public ScansOutOfCore {
 protected:
  std::string spec() const override { return "synth:corner?frames=41&width=320&height=240"; }
};

constexpr int kScans = 9;
/// Bytes a loaded 320 x 240 scan takes: points, normals, SSAO and border distance per pixel.
constexpr double kScanMb = 320.0 * 240 * 32 / (1 << 20);

TEST_F(ScansOutOfCoreLarger, AMemoryLimitOfAFewScansGivesTheSameBytesAsHoldingThemAll) {
  const testing::CliRun all = scans("all", "");
  ASSERT_EQ(all.exit_code, 0) << all.err;
  const nlohmann::json all_stats = read_stats(dir_.file("all"));
  EXPECT_EQ(all_stats["scans"], kScans);
  EXPECT_EQ(all_stats["scan_loads"], 0);  // every scan stayed in memory after the first stage
  EXPECT_EQ(all_stats["status"], "complete");
  EXPECT_FALSE(fs::exists(dir_.file("all/scratch")));  // removed after a complete run

  // Room for five loaded scans beyond what the process holds and the 64 MiB of slack: the first
  // stage needs 3.25 loaded scans' worth for one scan, the second two scans and an accumulator.
  const double before = all_stats["memory_before_mb"].get<double>();
  const int limit_mb = static_cast<int>(std::ceil(before + 64 + 5 * kScanMb));
  const testing::CliRun tight = scans("tight", "--memory-limit " + std::to_string(limit_mb) + "M");
  ASSERT_EQ(tight.exit_code, 0) << tight.err;
  const nlohmann::json stats = read_stats(dir_.file("tight"));
  EXPECT_GT(stats["scan_loads"].get<long long>(), 0);  // scans were dropped and read back
  EXPECT_EQ(stats["memory_limit_mb"], limit_mb);
  if (!kSanitized) {
    EXPECT_LE(stats["peak_rss_mb"].get<double>(), limit_mb);
  }
  EXPECT_EQ(ply("tight"), ply("all"));
  for (int frame = 0; frame <= 40; frame += 5) {
    const std::string name = "/scans/rec-" + std::to_string(frame) + ".ply";
    EXPECT_EQ(read_text(dir_.file("tight" + name)), read_text(dir_.file("all" + name))) << name;
  }
}

TEST_F(ScansOutOfCore, AResumedRunRecomputesOnlyWhatIsMissingOrDamaged) {
  const testing::CliRun all = scans("out", "--keep-scratch");
  ASSERT_EQ(all.exit_code, 0) << all.err;
  const std::string reference = ply("out");
  const fs::path scratch = dir_.file("out/scratch");
  ASSERT_TRUE(fs::exists(scratch / "run.json"));
  // As if the run had stopped during the integration: two MVAO files missing, one scan file cut
  // short, and the recording's record of its finished scans gone (so it is read again).
  fs::remove(scratch / "mvao-000000-000002.bin");
  fs::remove(scratch / "mvao-000000-000006.bin");
  fs::resize_file(scratch / "scan-000000-000004.bin", fs::file_size(scratch / "scan-000000-000004.bin") / 2);
  fs::remove(scratch / "unit-000000.json");

  const testing::CliRun resumed = scans("out", "--resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_NE(resumed.err.find("scan-000000-000004.bin: damaged scratch file"), std::string::npos)
      << resumed.err;
  const nlohmann::json stats = read_stats(dir_.file("out"));
  EXPECT_EQ(stats["scans_resumed"], kScans - 1);
  EXPECT_EQ(stats["integrations_resumed"], kScans - 2);
  EXPECT_EQ(ply("out"), reference);
  EXPECT_FALSE(fs::exists(scratch));

  // Nothing to resume: a warning, and a whole run.
  const testing::CliRun fresh = scans("out", "--resume");
  ASSERT_EQ(fresh.exit_code, 0) << fresh.err;
  EXPECT_NE(fresh.err.find("holds no earlier run"), std::string::npos) << fresh.err;
  EXPECT_EQ(read_stats(dir_.file("out"))["scans_resumed"], 0);
  EXPECT_EQ(ply("out"), reference);
}

TEST_F(ScansOutOfCore, ResumingWithOtherSettingsIsRefusedOrRedoesOnlyTheIntegration) {
  ASSERT_EQ(scans("out", "--keep-scratch").exit_code, 0);
  const testing::CliRun other = scans("out", "--resume --set ao.radius_m=0.15");
  EXPECT_EQ(other.exit_code, 2) << other.err;
  EXPECT_NE(other.err.find("--resume: "), std::string::npos) << other.err;
  EXPECT_NE(other.err.find("holds a run with another configuration; run without --resume"),
            std::string::npos)
      << other.err;
  EXPECT_EQ(testing::count(other.err, "\n"), 1u) << other.err;
  EXPECT_TRUE(fs::exists(dir_.file("out/scratch/run.json")));  // the earlier run is kept

  // A scratch folder of an earlier format (its scans without their range noise) is refused too.
  const std::string run_json = dir_.file("out/scratch/run.json");
  nlohmann::json run;
  {
    std::ifstream in(run_json);
    run = nlohmann::json::parse(in);
  }
  const nlohmann::json current = run;
  run["format"] = 1;
  std::ofstream(run_json) << run.dump(2) << "\n";
  const testing::CliRun earlier = scans("out", "--resume");
  EXPECT_EQ(earlier.exit_code, 2) << earlier.err;
  EXPECT_NE(earlier.err.find("holds a run with other inputs or settings; run without --resume"),
            std::string::npos)
      << earlier.err;
  std::ofstream(run_json) << current.dump(2) << "\n";

  // Another neighbourhood reuses every scan and integrates them all again.
  const testing::CliRun n5 = run_aoscan("scans " + quote(rec()) +
                                            " --every 5 --neighbourhood 5 --threads 2 --resume "
                                            "--out " + quote(dir_.file("out")),
                                        dir_.str());
  ASSERT_EQ(n5.exit_code, 0) << n5.err;
  const nlohmann::json stats = read_stats(dir_.file("out"));
  EXPECT_EQ(stats["scans_resumed"], kScans);
  EXPECT_EQ(stats["integrations_resumed"], 0);
  const testing::CliRun fresh = run_aoscan("scans " + quote(rec()) +
                                               " --every 5 --neighbourhood 5 --threads 2 --out " +
                                               quote(dir_.file("n5")),
                                           dir_.str());
  ASSERT_EQ(fresh.exit_code, 0) << fresh.err;
  EXPECT_EQ(ply("out"), ply("n5"));
}

TEST_F(ScansOutOfCore, AMemoryLimitBelowOneScanIsAUsageErrorNamingIt) {
  const testing::CliRun r = scans("out", "--memory-limit 1M");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("aoscan: error: --memory-limit 1 MiB is too small for scan rec-0 (a 160 x "
                       "120 map): give at least "),
            std::string::npos)
      << r.err;
  EXPECT_EQ(testing::count(r.err, "\n"), 1u) << r.err;
  EXPECT_FALSE(fs::exists(dir_.file("out/points.ply")));
  for (const char* bad : {"0", "12Q", "-5M"}) {
    const testing::CliRun b = scans("out", std::string("--memory-limit ") + bad);
    EXPECT_EQ(b.exit_code, 2) << bad << ": " << b.err;
    EXPECT_NE(b.err.find("--memory-limit"), std::string::npos) << b.err;
  }
}

TEST_F(ScansOutOfCore, AFullScratchDiskIsAnErrorNamingTheFileAndTheRunResumesAfterwards) {
  ASSERT_EQ(scans("reference", "").exit_code, 0);
  // A file size limit of 128 KiB stands for a full disk: a scan's scratch file (up to 675 KiB)
  // does not fit.
  const testing::CliRun full =
      run_aoscan("scans " + quote(rec()) + " --every 5 --neighbourhood 3 --threads 2 --out " +
                     quote(dir_.file("out")),
                 dir_.str(), "sh -c 'ulimit -f 128; exec \"$0\" \"$@\"'");
  EXPECT_EQ(full.exit_code, 1) << full.err;
  EXPECT_NE(full.err.find("aoscan: error: " + dir_.file("out/scratch/scan-000000-000000.bin") +
                          ": cannot write"),
            std::string::npos)
      << full.err;
  EXPECT_EQ(testing::count(full.err, "\n"), 1u) << full.err;
  EXPECT_FALSE(fs::exists(dir_.file("out/points.ply")));
  EXPECT_FALSE(fs::exists(dir_.file("out/stats.json")));
  EXPECT_FALSE(fs::exists(dir_.file("out/scratch/scan-000000-000000.bin.partial")));
  const testing::CliRun resumed = scans("out", "--resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_EQ(ply("out"), ply("reference"));
}

TEST_F(ScansOutOfCore, ASignalStopsBeforeTheNextScanAndResumeFinishesWithTheSameBytes) {
  // Every second frame a scan (21) at 5 x 5: seconds of work, stopped once its first scan is
  // written (the signal is taken from then on).
  const std::string set = quote(rec()) + " --every 2 --neighbourhood 5 --threads 2 --out ";
  const testing::CliRun whole = run_aoscan("scans " + set + quote(dir_.file("whole")), dir_.str());
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  testing::AoscanProcess run("scans " + set + quote(dir_.file("out")), fs::path(dir_.str()));
  ASSERT_TRUE(run.started());
  const fs::path first_scan = dir_.file("out/scratch/scan-000000-000000.bin");
  for (int i = 0; i < 3000 && !fs::exists(first_scan) && !run.poll(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_FALSE(run.poll()) << "the run ended before the signal: " << run.output().err;
  kill(run.pid(), SIGINT);
  const std::optional<int> code = run.wait_for(std::chrono::seconds(60));
  ASSERT_TRUE(code) << "no exit after SIGINT";
  const std::string err = run.output().err;
  EXPECT_EQ(*code, 1) << err;
  EXPECT_NE(err.find("aoscan: SIGINT: stopping before the next scan"), std::string::npos) << err;
  EXPECT_NE(err.find("aoscan: error: stopped before the outputs"), std::string::npos) << err;
  EXPECT_EQ(read_stats(dir_.file("out"))["status"], "interrupted");
  EXPECT_FALSE(fs::exists(dir_.file("out/points.ply")));
  EXPECT_TRUE(fs::exists(first_scan));
  const testing::CliRun resumed =
      run_aoscan("scans " + set + quote(dir_.file("out")) + " --resume", dir_.str());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_GT(read_stats(dir_.file("out"))["scans_resumed"].get<long long>(), 0);
  EXPECT_EQ(ply("out"), ply("whole"));
}

TEST_F(ScansOutOfCore, AScratchFolderInAnotherPlaceIsUsedAndOnlyItsOwnFilesRemoved) {
  const fs::path scratch = dir_.file("elsewhere");
  fs::create_directories(scratch);
  { std::ofstream(scratch / "notes.txt") << "keep me\n"; }
  const testing::CliRun r = scans("out", "--scratch " + quote(scratch.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir_.file("out/scratch")));
  EXPECT_EQ(read_text(scratch / "notes.txt"), "keep me\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(scratch), fs::directory_iterator()), 1);
  EXPECT_EQ(read_stats(dir_.file("out"))["scratch"], scratch.string());
}

}  // namespace
}  // namespace aoscan
