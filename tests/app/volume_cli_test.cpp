// End-to-end tests of `--save-volume` through the aoscan executable: volume.vdb as OpenVDB reads
// it, determinism, the voxel size option and one-line errors for an unusable output path.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Count.h>
#include <nlohmann/json.hpp>

#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace fs = std::filesystem;

namespace {

using aoscan::testing::CliRun;
using aoscan::testing::quote;
using aoscan::testing::read_text;
using aoscan::testing::run_aoscan;

/// A short synthetic recording (12 frames of 80x60 with Kinect noise).
fs::path make_recording(const fs::path& dir) {
  const fs::path rec = dir / "rec";
  const CliRun r =
      run_aoscan("record " + quote("synth:corner?frames=12&width=80&height=60&noise=kinect") + " " +
                  quote(rec.string()),
              dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return rec;
}

std::string replay_args(const fs::path& rec, const fs::path& out) {
  return "replay " + quote(rec.string()) + " --headless --no-progress --threads 2 --out " +
         quote(out.string());
}

TEST(VolumeCli, ReplayWritesAVolumeOpenVdbReads) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("replay");
  const fs::path rec = make_recording(dir);
  const fs::path out = dir / "out";
  const CliRun r = run_aoscan(replay_args(rec, out) + " --save-volume", dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json stats = nlohmann::json::parse(read_text(out / "stats.json"));
  ASSERT_TRUE(stats.contains("volume"));
  EXPECT_EQ(stats["volume"]["written"], true);

  openvdb::initialize();
  openvdb::io::File file((out / "volume.vdb").string());
  file.open();
  ASSERT_TRUE(file.hasGrid("tsdf"));
  ASSERT_TRUE(file.hasGrid("weight"));
  const auto tsdf = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tsdf"));
  const auto weight = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("weight"));
  file.close();
  ASSERT_TRUE(tsdf && weight);
  EXPECT_EQ(tsdf->getGridClass(), openvdb::GRID_LEVEL_SET);
  EXPECT_DOUBLE_EQ(tsdf->voxelSize()[0], 4.0 / 512.0);  // fusion.voxel_size_m's default
  EXPECT_EQ(tsdf->activeVoxelCount(), weight->activeVoxelCount());
  EXPECT_EQ(static_cast<std::size_t>(tsdf->activeVoxelCount()),
            stats["volume"]["active_voxels"].get<std::size_t>());
  // The surface lies in front of the first camera (world = the first frame's camera frame):
  // some observed voxels are negative (behind the surface), every weight is positive.
  const openvdb::math::MinMax<float> sdf = openvdb::tools::minMax(tsdf->tree());
  EXPECT_LT(sdf.min(), 0.0f);
  EXPECT_GT(sdf.max(), 0.0f);
  EXPECT_GE(openvdb::tools::minMax(weight->tree()).min(), 1.0f);

  // Same input, same threads: the same bytes.
  const fs::path again = dir / "again";
  ASSERT_EQ(run_aoscan(replay_args(rec, again) + " --save-volume", dir).exit_code, 0);
  EXPECT_EQ(read_text(out / "volume.vdb"), read_text(again / "volume.vdb"));

  // The voxel size follows fusion.voxel_size_m.
  const fs::path coarse = dir / "coarse";
  ASSERT_EQ(
      run_aoscan(replay_args(rec, coarse) +
                  " --save-volume --set fusion.voxel_size_m=0.02 --set fusion.truncation_m=0.08",
              dir)
          .exit_code,
      0);
  openvdb::io::File coarse_file((coarse / "volume.vdb").string());
  coarse_file.open();
  EXPECT_DOUBLE_EQ(coarse_file.readGrid("tsdf")->voxelSize()[0], 0.02);
  coarse_file.close();
}

/// Exactly one line on stderr, starting with "aoscan: error:" and naming `needle`.
void expect_one_line_error(const CliRun& r, const std::string& needle) {
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  EXPECT_EQ(r.err.rfind("aoscan: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
}

TEST(VolumeCli, UnusableOutputPathExitsTwoWithOneLine) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("bad_out");
  const fs::path rec = make_recording(dir);
  // --out under a regular file.
  std::ofstream(dir / "file") << "x";
  CliRun r = run_aoscan(replay_args(rec, dir / "file" / "sub") + " --save-volume", dir);
  EXPECT_EQ(r.exit_code, 2);
  expect_one_line_error(r, "--out");
  // A folder named volume.vdb in the way: refused before the run, nothing written.
  const fs::path out = dir / "out";
  fs::create_directories(out / "volume.vdb");
  r = run_aoscan(replay_args(rec, out) + " --save-volume", dir);
  EXPECT_EQ(r.exit_code, 2);
  expect_one_line_error(r, "volume.vdb");
  EXPECT_FALSE(fs::exists(out / "mesh.ply"));
  // Without --save-volume the same folder is fine.
  r = run_aoscan(replay_args(rec, out), dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

}  // namespace
