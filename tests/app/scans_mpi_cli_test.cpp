// `aoscan scans` as two MPI ranks (`mpirun -np 2 --oversubscribe`): the same bytes as one process,
// and a rank that meets bad input ends the job with the contract's exit code and its one-line
// error. Skips where aoscan is built without MPI, and in sanitizer builds (Open MPI's own memory
// hooks and leaks at exit do not agree with AddressSanitizer).
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

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

/// The launcher prefix for two ranks on this machine (root allowed: CI runs as root).
std::string mpirun_two() {
  return std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ") +
         quote(AOSCAN_MPIEXEC) + " -np 2 --oversubscribe";
}

void skip_without_mpi() {
#if defined(AOSCAN_SANITIZED)
  GTEST_SKIP() << "sanitizer build: Open MPI is not run under AddressSanitizer";
#endif
  if (std::string(AOSCAN_MPIEXEC).empty()) GTEST_SKIP() << "aoscan is built without MPI";
}

TEST(ScansMpi, TwoRanksGiveTheSameBytesAsOneProcess) {
  skip_without_mpi();
  if (::testing::Test::IsSkipped()) return;
  ScratchDir dir;
  // Two recordings (two input units, whose scans the ranks deal out in turn) of 17 frames.
  for (const char* name : {"a", "b"}) {
    const std::string spec = std::string("synth:corner?frames=17&width=160&height=120&seed=") +
                             (name[0] == 'a' ? "1" : "2");
    ASSERT_EQ(run_aoscan("record " + quote(spec) + " " + quote(dir.file(name)), dir.str()).exit_code, 0);
  }
  const std::string args = "scans " + quote(dir.file("a")) + " " + quote(dir.file("b")) +
                           " --every 4 --neighbourhood 3 --out ";
  const testing::CliRun one = run_aoscan(args + quote(dir.file("one")) + " --threads 1", dir.str());
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const testing::CliRun two =
      run_aoscan(args + quote(dir.file("two")) + " --threads 1", dir.str(), mpirun_two());
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_EQ(testing::count(two.err, "points.ply\n"), 1u) << "one summary line, from rank 0: " << two.err;
  const nlohmann::json stats = read_stats(dir.file("two"));
  EXPECT_EQ(stats["ranks"], 2);
  EXPECT_EQ(stats["scans"], 10);  // frames 0, 4, ..., 16 of each recording
  EXPECT_EQ(stats["pairs_tested"], read_stats(dir.file("one"))["pairs_tested"]);
  EXPECT_EQ(read_text(dir.file("two/points.ply")), read_text(dir.file("one/points.ply")));
  for (const char* scan : {"a-0", "a-16", "b-4", "b-12"}) {
    const std::string file = std::string("/scans/") + scan + ".ply";
    EXPECT_EQ(read_text(dir.file("two" + file)), read_text(dir.file("one" + file))) << file;
  }
  EXPECT_FALSE(fs::exists(dir.file("two/scratch")));
}

TEST(ScansMpi, ARankThatMeetsBadInputEndsTheJobWithItsError) {
  skip_without_mpi();
  if (::testing::Test::IsSkipped()) return;
  ScratchDir dir;
  const fs::path rec = testing::record_corner(dir.str(), 3, 64, 48);
  // A manifest of two depth images: the second, scan 0 of unit 1, is rank 1's, and not a PNG.
  { std::ofstream(dir.file("broken.png")) << "not a png\n"; }
  {
    std::ofstream manifest(dir.file("set.yaml"));
    manifest << "scans:\n"
             << "  - depth: " << (rec / "depth" / "000000.png").string() << "\n"
             << "    camera: {fx: 52.5, fy: 52.5, cx: 31.5, cy: 23.5, depth_scale: 5000}\n"
             << "  - depth: " << dir.file("broken.png") << "\n"
             << "    camera: {fx: 52.5, fy: 52.5, cx: 31.5, cy: 23.5, depth_scale: 5000}\n";
  }
  const testing::CliRun r = run_aoscan("scans " + quote(dir.file("set.yaml")) + " --threads 1 --out " +
                                           quote(dir.file("out")),
                                       dir.str(), mpirun_two());
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("aoscan: error: " + dir.file("broken.png")), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(rank 1 of 2)"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.file("out/points.ply")));
  EXPECT_FALSE(fs::exists(dir.file("out/stats.json")));
}

}  // namespace
}  // namespace aoscan
