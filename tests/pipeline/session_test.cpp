// Tests for src/pipeline/session.cpp: stats.json content and exit codes of a run.
#include "pipeline/session.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fake_source.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST(Session, WritesStatsJsonWithTheContractKeys) {
  aoscan::testing::ScratchDir scratch;
  testing::FakeSource source(25);
  source.corrupt_ = {4};
  RunOptions options;
  options.out_dir = scratch.file("session_stats");
  options.threads = 1;
  std::atomic<bool> stop{false};
  const SessionResult r = run_session(source, options, stop);
  EXPECT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  const nlohmann::json j = read_json(fs::path(options.out_dir) / "stats.json");
  EXPECT_EQ(j["frames_read"], 24);
  EXPECT_EQ(j["frames_processed"], 24);
  EXPECT_EQ(j["frames_corrupt"], 1);
  EXPECT_EQ(j["frames_dropped"], 0);
  const nlohmann::json zero_drops = {
      {"preprocess", 0}, {"filter", 0}, {"track", 0}, {"ssao", 0}, {"mvao", 0}};
  EXPECT_EQ(j["frames_dropped_at"], zero_drops);
  // The fake frames are a tiny flat wall; whether ICP keeps them is fusion's business (tested
  // there): here only the counter's presence and range.
  EXPECT_LE(j["frames_tracking_lost"].get<int>(), 24);
  EXPECT_EQ(j["threads"], 1);
  EXPECT_GT(j["wall_s"].get<double>(), 0.0);
  EXPECT_NEAR(j["fps"].get<double>(), 24.0 / j["wall_s"].get<double>(), 1e-6);
  EXPECT_GE(j["export_s"].get<double>(), 0.0);
  EXPECT_GT(j["peak_rss_mb"].get<double>(), 1.0);
  ASSERT_TRUE(j.contains("host_steal_percent"));
  if (!j["host_steal_percent"].is_null()) {  // null where /proc/stat cannot tell
    EXPECT_GE(j["host_steal_percent"].get<double>(), 0.0);
    EXPECT_LE(j["host_steal_percent"].get<double>(), 100.0);
  }
  for (const char* stage : {"capture", "preprocess", "filter", "track", "ssao", "mvao"}) {
    ASSERT_TRUE(j["stages"].contains(stage)) << stage;
    const auto& s = j["stages"][stage];
    EXPECT_LE(s["ms_p50"].get<double>(), s["ms_max"].get<double>());
    EXPECT_LE(s["ms_p95"].get<double>(), s["ms_max"].get<double>());
  }
}

TEST(Session, DeviceLossStillWritesOutputsAndExitsFour) {
  aoscan::testing::ScratchDir scratch;
  testing::FakeSource source(30);
  source.fail_at_ = 12;
  RunOptions options;
  options.out_dir = scratch.file("session_unplug");
  std::atomic<bool> stop{false};
  const SessionResult r = run_session(source, options, stop);
  EXPECT_EQ(r.exit_code, ExitCode::kDevice);
  EXPECT_NE(r.error.find("unplugged"), std::string::npos);
  const nlohmann::json j = read_json(fs::path(options.out_dir) / "stats.json");
  EXPECT_EQ(j["frames_processed"], 12);
}

TEST(Session, NothingUsableIsBadInput) {
  aoscan::testing::ScratchDir scratch;
  testing::FakeSource source(3);
  source.corrupt_ = {0, 1, 2};
  RunOptions options;
  options.out_dir = scratch.file("session_empty");
  std::atomic<bool> stop{false};
  const SessionResult r = run_session(source, options, stop);
  EXPECT_EQ(r.exit_code, ExitCode::kBadInput);
  EXPECT_NE(r.error.find("no usable frame"), std::string::npos);
}

TEST(Session, UncreatableOutputFolderIsAUsageError) {
  aoscan::testing::ScratchDir scratch;
  testing::FakeSource source(3);
  RunOptions options;
  const fs::path file = scratch.path("session_file");
  std::ofstream(file) << "x";
  options.out_dir = (file / "sub").string();
  std::atomic<bool> stop{false};
  try {
    run_session(source, options, stop);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
  }
}

}  // namespace
}  // namespace aoscan
