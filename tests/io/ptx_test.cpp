// Tests for src/io/ptx.cpp and src/io/meshlab_project.cpp: the scan-set formats of laser
// scanners and of MeshLab, with exact registrations and one-line errors.
#include "io/ptx.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "core/status.h"
#include "io/meshlab_project.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;
using testing::write_text;

/// A PTX header for a columns x rows grid registered by a rotation of 90 degrees about z and a
/// translation (1, 2, 3), written the PTX way (transposed: the translation on the last line).
std::string header(int columns, int rows) {
  return std::to_string(columns) + "\n" + std::to_string(rows) +
         "\n1 2 3\n0 1 0\n-1 0 0\n0 0 1\n"
         "0 1 0 0\n-1 0 0 0\n0 0 1 0\n1 2 3 1\n";
}

std::string error_of(const std::string& path) {
  try {
    read_ptx(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Ptx, ReadsEveryScanWithItsRegistrationAndSkipsMissingPoints) {
  ScratchDir dir;
  write_text(dir.file("s.ptx"), header(2, 2) +
                                    "1 0 0 0.5\n0 0 0 0\n0 2 0 0.5 10 20 30\n0 0 3 0.1\n" +
                                    header(1, 1) + "5 5 5 1\n");
  const std::vector<PtxScan> scans = read_ptx(dir.file("s.ptx"));
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].columns, 2);
  EXPECT_EQ(scans[0].rows, 2);
  EXPECT_EQ(scans[0].missing, 1);
  ASSERT_EQ(scans[0].points.size(), 3u);
  EXPECT_EQ(scans[0].points[1], Eigen::Vector3f(0, 2, 0));
  // x of the scanner frame maps to +y of the world, plus the translation.
  EXPECT_TRUE((scans[0].T_world_scanner * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(1, 3, 3)));
  EXPECT_EQ(scans[1].points.size(), 1u);
}

TEST(Ptx, APointThatIsNotFiniteIsKeptAsReadForTheRasteriserToSkip) {
  ScratchDir dir;
  write_text(dir.file("s.ptx"),
             header(2, 2) + "nan nan nan 0.5\n1 0 0 0.5\n0 inf 0 0.5\n-INF 2 NaN nan\n");
  const std::vector<PtxScan> scans = read_ptx(dir.file("s.ptx"));
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_EQ(scans[0].missing, 0);
  ASSERT_EQ(scans[0].points.size(), 4u);
  EXPECT_TRUE(std::isnan(scans[0].points[0].x()));
  EXPECT_EQ(scans[0].points[1], Eigen::Vector3f(1, 0, 0));
  EXPECT_TRUE(std::isinf(scans[0].points[2].y()));
  EXPECT_TRUE(std::isinf(scans[0].points[3].x()) && scans[0].points[3].x() < 0.0f);
  EXPECT_EQ(scans[0].points[3].y(), 2.0f);
  EXPECT_TRUE(std::isnan(scans[0].points[3].z()));
}

TEST(Ptx, BadFilesAreOneLineErrorsWithTheLine) {
  ScratchDir dir;
  const struct {
    std::string text, expected;
  } cases[] = {
      {"", "holds no scan"},
      {header(2, 2) + "1 0 0 0.5\n", "ends after 1 of the scan's 4 points"},
      {"2\n", "ends inside a scan header"},
      {"0\n3\n", "two positive whole numbers"},
      {header(1, 1) + "1 2 x 4\n", ":11: not a number"},
      {"1\nnan\n", ":2: not a number"},
      {"1\n1\n0 0 inf\n", ":3: not a number"},
      {"1\n1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\nnan 0 0 1\n1 1 1 1\n",
       ":10: not a number"},
      {header(1, 1) + "1 2 3 4 5\n", "x y z intensity [r g b]"},
      {"1\n1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n1 1 1 1\n",
       "not a rigid transform"},
  };
  for (const auto& c : cases) {
    write_text(dir.file("bad.ptx"), c.text);
    const std::string message = error_of(dir.file("bad.ptx"));
    EXPECT_NE(message.find(c.expected), std::string::npos) << c.text << " -> " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
  EXPECT_NE(error_of(dir.file("absent.ptx")).find("cannot open"), std::string::npos);
}

TEST(MeshlabProject, ReadsTheLayersWithTheirMatrices) {
  ScratchDir dir;
  write_text(dir.file("a.ply"), "x");
  write_text(dir.file("b.ply"), "x");
  write_text(dir.file("p.mlp"), R"(<!DOCTYPE MeshLabDocument>
<MeshLabProject>
 <MeshGroup>
  <MLMesh label="hall" filename="a.ply">
   <MLMatrix44>
1 0 0 4 
0 1 0 5 
0 0 1 6 
0 0 0 1 
</MLMatrix44>
  </MLMesh>
  <MLMesh filename="b.ply"/>
 </MeshGroup>
 <RasterGroup/>
</MeshLabProject>
)");
  const std::vector<ScanEntry> scans = read_meshlab_project(dir.file("p.mlp"));
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].name, "hall");
  EXPECT_EQ(scans[0].kind, ScanEntry::Kind::kPointCloud);
  EXPECT_TRUE(scans[0].T_world_scan.translation().isApprox(Eigen::Vector3d(4, 5, 6)));
  EXPECT_EQ(scans[1].name, "b");
  EXPECT_EQ(scans[1].path, dir.file("b.ply"));
  EXPECT_TRUE(scans[1].T_world_scan.matrix().isIdentity());
}

TEST(MeshlabProject, BadProjectsAreOneLineErrors) {
  ScratchDir dir;
  write_text(dir.file("a.ply"), "x");
  write_text(dir.file("a.obj"), "x");
  auto project = [](const std::string& layers) {
    return "<MeshLabProject><MeshGroup>" + layers + "</MeshGroup></MeshLabProject>";
  };
  const struct {
    std::string text, expected;
  } cases[] = {
      {"<MeshLabProject>", "not a MeshLab project (XML error"},
      {"<Other/>", "no MeshGroup"},
      {project(""), "has no layer"},
      {project("<MLMesh label=\"x\"/>"), "layer 1: no filename"},
      {project("<MLMesh filename=\"gone.ply\"/>"), "layer 1 (gone): no such file"},
      {project("<MLMesh filename=\"a.obj\"/>"), "is not a PLY file"},
      {project("<MLMesh filename=\"a.ply\"><MLMatrix44>1 0 0</MLMatrix44></MLMesh>"),
       "16 finite numbers"},
      {project("<MLMesh filename=\"a.ply\"><MLMatrix44>2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</MLMatrix44>"
               "</MLMesh>"),
       "not a rigid transform"},
      {project("<MLMesh filename=\"a.ply\"/><MLMesh filename=\"a.ply\"/>"),
       "another layer is named a"},
      // A file name too long for the file system (ENAMETOOLONG) is missing, not an escaping
      // std::filesystem exception (as fuzz/scan_manifest_fuzz found for scan manifests).
      {project("<MLMesh label=\"long\" filename=\"" + std::string(300, 'x') + ".ply\"/>"),
       "layer 1 (long): no such file"},
      // Found by fuzz/meshlab_project_fuzz: a label ending in '/' gave a layer an empty name.
      {project("<MLMesh label=\"/scan/\" filename=\"a.ply\"/>"),
       "p.mlp: layer 1: label '/scan/' is not a name"},
  };
  for (const auto& c : cases) {
    write_text(dir.file("p.mlp"), c.text);
    std::string message;
    try {
      read_meshlab_project(dir.file("p.mlp"));
    } catch (const Error& e) {
      message = e.what();
    }
    EXPECT_NE(message.find(c.expected), std::string::npos) << c.text << " -> " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace aoscan
