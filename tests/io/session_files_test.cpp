// Tests for src/io/session_files.cpp: keyframes and grid cells written and read back exactly,
// and every damaged file refused with a message naming it: truncated at any byte, a flipped
// byte, another magic or version, a database larger than allowed, a non-rigid pose.
#include "io/session_files.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "core/status.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

SavedKeyframes two_keyframes() {
  SavedKeyframes k;
  k.ferns = 5;
  k.fern_decisions = 3;
  for (int i = 0; i < 2; ++i) {
    SavedKeyframe f;
    f.codes = {0, 1, 7, static_cast<std::uint8_t>(i), 3};
    f.T_world_camera.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd(0.3 * (i + 1), Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    f.T_world_camera.topRightCorner<3, 1>() = Eigen::Vector3d(0.1 * i, -2.5, 1e-3);
    f.depth_mm.resize(4, 3, 0);
    for (std::size_t p = 0; p < f.depth_mm.size(); ++p)
      f.depth_mm.data()[p] = static_cast<std::uint16_t>(1000 + 37 * p + i);
    k.keyframes.push_back(f);
  }
  return k;
}

SavedGrid three_cells() {
  SavedGrid g;
  g.cell_size_m = 4.0 / 512;
  g.integration = 1;
  g.frames = 77;
  g.cells = {{-3, 0, 12, 0.25f, 0.5f, 3}, {1 << 19, -(1 << 19), 5, 0.0f, 2.0f, 77},
             {0, 0, 0, 1.5f, 1.5f, 1}};
  return g;
}

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void put_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST(SessionFiles, KeyframesAndCellsRoundTripExactly) {
  testing::ScratchDir scratch;
  const SavedKeyframes k = two_keyframes();
  write_keyframes(scratch.file("k.db"), k);
  const SavedKeyframes back = read_keyframes(scratch.file("k.db"), 10);
  EXPECT_EQ(back.ferns, 5u);
  EXPECT_EQ(back.fern_decisions, 3u);
  ASSERT_EQ(back.keyframes.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(back.keyframes[i].codes, k.keyframes[i].codes);
    EXPECT_EQ(back.keyframes[i].T_world_camera, k.keyframes[i].T_world_camera);  // bit for bit
    ASSERT_EQ(back.keyframes[i].depth_mm.width(), 4);
    for (std::size_t p = 0; p < 12; ++p)
      EXPECT_EQ(back.keyframes[i].depth_mm.data()[p], k.keyframes[i].depth_mm.data()[p]);
  }
  const SavedGrid g = three_cells();
  write_grid(scratch.file("g.grid"), g);
  const SavedGrid gb = read_grid(scratch.file("g.grid"));
  EXPECT_EQ(gb.cell_size_m, g.cell_size_m);
  EXPECT_EQ(gb.integration, 1u);
  EXPECT_EQ(gb.frames, 77u);
  ASSERT_EQ(gb.cells.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(gb.cells[i].x, g.cells[i].x);
    EXPECT_EQ(gb.cells[i].y, g.cells[i].y);
    EXPECT_EQ(gb.cells[i].z, g.cells[i].z);
    EXPECT_EQ(gb.cells[i].ao_weight_sum, g.cells[i].ao_weight_sum);
    EXPECT_EQ(gb.cells[i].weight_sum, g.cells[i].weight_sum);
    EXPECT_EQ(gb.cells[i].last_frame, g.cells[i].last_frame);
  }
}

TEST(SessionFiles, EveryTruncationAndFlippedByteIsRefusedNamingTheFile) {
  testing::ScratchDir scratch;
  const std::string kf = scratch.file("k.db"), grid = scratch.file("g.grid");
  write_keyframes(kf, two_keyframes());
  write_grid(grid, three_cells());
  for (const std::string& path : {kf, grid}) {
    const std::string good = bytes_of(path);
    const auto read = [&] {
      if (path == kf)
        read_keyframes(path, 10);
      else
        read_grid(path);
    };
    for (std::size_t n = 0; n < good.size(); ++n) {
      put_bytes(path, good.substr(0, n));
      const std::string message = testing::error_message(read, ExitCode::kBadInput);
      ASSERT_EQ(message.rfind(path + ": ", 0), 0u) << n << ": " << message;
    }
    for (std::size_t n = 0; n < good.size(); n += 3) {
      std::string bad = good;
      bad[n] = static_cast<char>(bad[n] ^ 0x5a);
      put_bytes(path, bad);
      testing::error_message(read, ExitCode::kBadInput);
    }
    put_bytes(path, good);
    EXPECT_NO_THROW(read());
  }
}

TEST(SessionFiles, AnotherVersionOrALargerDatabaseThanAllowedIsRefused) {
  testing::ScratchDir scratch;
  const std::string kf = scratch.file("k.db");
  write_keyframes(kf, two_keyframes());
  EXPECT_EQ(testing::error_message([&] { read_keyframes(kf, 1); }, ExitCode::kBadInput),
            kf + ": holds 2 keyframes, more than relocalisation.max_keyframes (1) allows");
  std::string bytes = bytes_of(kf);
  bytes[8] = 9;  // the version field, after the 8-byte magic
  put_bytes(kf, bytes);
  EXPECT_EQ(testing::error_message([&] { read_keyframes(kf, 10); }, ExitCode::kBadInput),
            kf + ": session format version 9, this aoscan reads version 1");
  put_bytes(kf, "not a session file at all, but long enough");
  EXPECT_EQ(testing::error_message([&] { read_keyframes(kf, 10); }, ExitCode::kBadInput),
            kf + ": not a session file of aoscan");
  EXPECT_EQ(testing::error_message([&] { read_grid(scratch.file("missing")); },
                                   ExitCode::kBadInput),
            scratch.file("missing") + ": cannot be read");
}

TEST(SessionFiles, TheFuzzSeedsAreValidFilesOfThisFormat) {
  // fuzz/corpus/session_files/ holds a keyframe file and a grid file, each behind the byte that
  // picks its reader: written by hand from the layout, they pin the byte format down.
  testing::ScratchDir scratch;
  const fs::path corpus = fs::path(AOSCAN_SOURCE_DIR) / "fuzz" / "corpus" / "session_files";
  put_bytes(scratch.file("k.db"), bytes_of((corpus / "two_keyframes").string()).substr(1));
  const SavedKeyframes k = read_keyframes(scratch.file("k.db"), 10);
  ASSERT_EQ(k.keyframes.size(), 2u);
  EXPECT_EQ(k.keyframes[1].codes, two_keyframes().keyframes[1].codes);
  EXPECT_EQ(k.keyframes[1].depth_mm(3, 2), two_keyframes().keyframes[1].depth_mm(3, 2));
  put_bytes(scratch.file("g.grid"), bytes_of((corpus / "three_cells").string()).substr(1));
  const SavedGrid g = read_grid(scratch.file("g.grid"));
  ASSERT_EQ(g.cells.size(), 3u);
  EXPECT_EQ(g.cells[1].x, 1 << 19);
  EXPECT_EQ(g.frames, 77u);
}

TEST(SessionFiles, ANonRigidPoseIsRefused) {
  testing::ScratchDir scratch;
  SavedKeyframes k = two_keyframes();
  k.keyframes[1].T_world_camera(0, 0) = 2.0;  // a scale, not a rotation
  write_keyframes(scratch.file("k.db"), k);
  const std::string message =
      testing::error_message([&] { read_keyframes(scratch.file("k.db"), 10); });
  EXPECT_NE(message.find("not a rigid transform"), std::string::npos) << message;
}

}  // namespace
}  // namespace aoscan
