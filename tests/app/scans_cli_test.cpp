// End-to-end tests of `aoscan scans` through the executable: a recording folder in, the contract's
// outputs out; exit codes and one-line errors for bad options and inputs.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::quote;
using testing::read_stats;
using testing::run_aoscan;
using testing::ScratchDir;

TEST(ScansCli, ARecordingFolderGivesTheContractsOutputs) {
  ScratchDir dir;
  const std::string rec = dir.file("rec");
  ASSERT_EQ(run_aoscan("record 'synth:corner?frames=21&width=160&height=120' " + quote(rec),
                       dir.str())
                .exit_code,
            0);
  const std::string out = dir.file("out");
  const testing::CliRun r = run_aoscan("scans " + quote(rec) + " --out " + quote(out) +
                                           " --every 10 --neighbourhood 3 --threads 1 --mesh "
                                           "--set ao.radius_m=0.15",
                                       dir.str());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("3 scans"), std::string::npos) << r.err;
  for (const char* file :
       {"points.ply", "stats.json", "scans/rec-0.ply", "scans/rec-20.ply", "mesh.ply"})
    EXPECT_TRUE(std::filesystem::is_regular_file(std::filesystem::path(out) / file)) << file;
  const nlohmann::json stats = read_stats(out);
  EXPECT_EQ(stats["scans"], 3);
  EXPECT_EQ(stats["neighbourhood"], 3);
  for (const char* key : {"points", "wall_s", "peak_rss_mb"}) EXPECT_TRUE(stats.contains(key));
  EXPECT_GT(stats["mesh"]["faces"].get<long long>(), 0);
}

TEST(ScansCli, BadOptionsAndInputsAreOneLineErrorsWithTheContractsExitCodes) {
  ScratchDir dir;
  const struct {
    std::string args;
    int exit_code;
    std::string expected;
  } cases[] = {
      {"scans", 2, "INPUT is required"},
      {"scans " + quote(dir.str()) + " --neighbourhood 4", 2, "not in {1,3,5,7,9}"},
      {"scans " + quote(dir.file("absent.yaml")), 3, "absent.yaml: cannot open the scan manifest"},
      {"scans " + quote(dir.file("absent")), 3, "absent: no such file or folder"},
      {"scans " + quote(dir.str()) + " --set ao.radius_m=-1", 2, "ao.radius_m"},
      {"scans " + quote(dir.str()), 3, "no trajectory.txt or groundtruth.txt"},
  };
  for (const auto& c : cases) {
    const testing::CliRun r = run_aoscan(c.args + " --out " + quote(dir.file("out")), dir.str());
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << ": " << r.err;
    EXPECT_NE(r.err.find("aoscan: error: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << ": " << r.err;
    EXPECT_EQ(testing::count(r.err, "\n"), 1u) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("out/points.ply")));
}

}  // namespace
}  // namespace aoscan
