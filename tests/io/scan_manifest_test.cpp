// Tests for src/io/scan_manifest.cpp: both pose forms, JSON and YAML, relative paths, and the
// one-line errors for every kind of bad manifest.
#include "io/scan_manifest.h"

#include <string>

#include <gtest/gtest.h>

#include "core/status.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;
using testing::write_text;

/// The message of the Error that reading `text` as a manifest throws, or "" when none.
std::string error_of(const ScratchDir& dir, const std::string& text) {
  write_text(dir.file("m.yaml"), text);
  try {
    read_scan_manifest(dir.file("m.yaml"));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ScanManifest, ReadsDepthAndPointScansWithBothPoseForms) {
  ScratchDir dir;
  std::filesystem::create_directories(dir.file("d"));
  write_text(dir.file("d/a.png"), "x");
  write_text(dir.file("laser.ply"), "x");
  write_text(dir.file("m.yaml"), R"(scans:
  - depth: d/a.png
    camera: {fx: 500, fy: 501, cx: 319.5, cy: 239.5, depth_scale: 1000}
    pose: [0, -1, 0, 1,  1, 0, 0, 2,  0, 0, 1, 3,  0, 0, 0, 1]
  - name: hall
    points: laser.ply
    scanner: [0, 0, 1.5]
    pose: {t: [4, 5, 6], q: [0, 0, 0, 1]}
)");
  const std::vector<ScanEntry> scans = read_scan_manifest(dir.file("m.yaml"));
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].name, "a");
  EXPECT_EQ(scans[0].kind, ScanEntry::Kind::kDepthImage);
  EXPECT_EQ(scans[0].path, dir.file("d/a.png"));
  EXPECT_EQ(scans[0].intrinsics.fy, 501.0);
  EXPECT_EQ(scans[0].depth_scale, 1000.0);
  EXPECT_TRUE(
      (scans[0].T_world_scan * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(1, 3, 3)));
  EXPECT_EQ(scans[1].name, "hall");
  EXPECT_EQ(scans[1].kind, ScanEntry::Kind::kPointCloud);
  EXPECT_EQ(scans[1].scanner, Eigen::Vector3d(0, 0, 1.5));
  EXPECT_TRUE(scans[1].T_world_scan.translation().isApprox(Eigen::Vector3d(4, 5, 6)));
}

TEST(ScanManifest, JsonWorksToo) {
  ScratchDir dir;
  write_text(dir.file("c.ply"), "x");
  write_text(dir.file("m.json"), R"({"scans": [{"points": "c.ply"}]})");
  const std::vector<ScanEntry> scans = read_scan_manifest(dir.file("m.json"));
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_EQ(scans[0].name, "c");
  EXPECT_TRUE(scans[0].T_world_scan.matrix().isIdentity());
}

TEST(ScanManifest, BadManifestsAreOneLineErrorsNamingTheScan) {
  ScratchDir dir;
  write_text(dir.file("c.ply"), "x");
  const std::string cam = "camera: {fx: 1, fy: 1, cx: 0, cy: 0, depth_scale: 1}";
  const struct {
    std::string text, expected;
  } cases[] = {
      {"scans: [", "not valid YAML or JSON"},
      {"other: 1", "needs a list 'scans'"},
      {"scans: []", "lists no scan"},
      {"scans: [{points: missing.ply}]", "scan 1 (missing): no such file"},
      {"scans: [{points: c.ply, depth: c.ply}]", "exactly one of depth"},
      {"scans: [{depth: c.ply}]", "needs camera"},
      {"scans: [{depth: c.ply, camera: {fx: 1, fy: 1, cx: 0, cy: 0}}]", "camera lacks depth_scale"},
      {"scans: [{depth: c.ply, camera: {fx: -1, fy: 1, cx: 0, cy: 0, depth_scale: 1}}]",
       "must be positive"},
      {"scans: [{points: c.ply, pose: [1, 2, 3]}]", "list of 16 numbers"},
      {"scans: [{points: c.ply, pose: [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]",
       "not a rigid transform"},
      {"scans: [{points: c.ply, pose: {t: [0, 0, 0], q: [0, 0, 0, 0]}}]", "zero quaternion"},
      {"scans: [{points: c.ply, pose: [.nan,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]", "not finite"},
      {"scans: [{points: c.ply}, {points: c.ply}]", "scan 2 (c): another scan has this name"},
      {"scans: [{points: c.ply, scanner: [0, 0]}]", "list of 3 numbers"},
      {"scans: [{depth: c.ply, " + cam + ", scanner: [0, 0, 0]}]", "scanner is for point clouds"},
      {"scans: [{points: c.ply, colour: red}]", "unknown key 'colour'"},
      // Found by fuzz/scan_manifest_fuzz: a file name too long for the file system (ENAMETOOLONG)
      // escaped as std::filesystem's exception.
      {"scans: [{name: long, points: " + std::string(300, 'x') + ".ply}]",
       "scan 1 (long): no such file"},
  };
  for (const auto& c : cases) {
    const std::string message = error_of(dir, c.text);
    EXPECT_NE(message.find(c.expected), std::string::npos) << c.text << " -> " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  EXPECT_NE(error_of(dir, "").find("needs a list"), std::string::npos);
  try {
    read_scan_manifest(dir.file("absent.yaml"));
    ADD_FAILURE() << "no error for a missing manifest";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos);
  }
}

}  // namespace
}  // namespace aoscan
