// Tests for src/io/vdb.cpp: volume.vdb as OpenVDB sees it (grid names, classes, transform,
// exact voxel values), read-back, determinism and errors.
#include "io/vdb.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include "core/status.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

constexpr double kVoxel = 0.01;
constexpr double kTruncation = 0.04;

int local_index(int x, int y, int z) {
  return x + kBrickSize * (y + kBrickSize * z);
}

/// Two bricks, one at negative coordinates. Brick 0 observes only voxels with x == y (value
/// 0.001 * (x + 8 y + 64 z) - 0.2, weight 1 + z); brick 1 observes every voxel; a third brick is
/// entirely unobserved.
std::vector<VolumeBrick> sample_bricks() {
  std::vector<VolumeBrick> bricks(3);
  bricks[0].origin = Eigen::Vector3i(8, 0, -16);
  bricks[1].origin = Eigen::Vector3i(-8, -8, 0);
  bricks[2].origin = Eigen::Vector3i(64, 64, 64);
  for (VolumeBrick& b : bricks) {
    b.sdf_m.fill(static_cast<float>(kTruncation));
    b.weight.fill(0.0f);
  }
  for (int z = 0; z < 8; ++z)
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        const int i = local_index(x, y, z);
        if (x == y) {
          bricks[0].sdf_m[i] = 0.001f * static_cast<float>(i) - 0.2f;
          bricks[0].weight[i] = 1.0f + static_cast<float>(z);
        }
        bricks[1].sdf_m[i] = -0.03f + 0.0001f * static_cast<float>(i);
        bricks[1].weight[i] = 100.0f;
      }
  return bricks;
}

VolumeView view_of(const std::vector<VolumeBrick>& bricks, bool reversed = false) {
  VolumeView view;
  view.voxel_size_m = kVoxel;
  view.truncation_m = kTruncation;
  view.brick_count = bricks.size();
  view.brick = [&bricks, reversed](std::size_t i, VolumeBrick& out) {
    out = bricks[reversed ? bricks.size() - 1 - i : i];
  };
  return view;
}

TEST(Vdb, OpenVdbReadsTheGridsWithExactValues) {
  testing::ScratchDir dir;
  const std::vector<VolumeBrick> bricks = sample_bricks();
  const VdbWriteStats stats = write_volume_vdb(dir.file("volume.vdb"), view_of(bricks));
  EXPECT_EQ(stats.bricks, 2u);
  EXPECT_EQ(stats.active_voxels, 64u + 512u);
  EXPECT_EQ(stats.file_bytes, std::filesystem::file_size(dir.file("volume.vdb")));

  openvdb::initialize();
  openvdb::io::File file(dir.file("volume.vdb"));
  file.open();
  std::vector<std::string> names;
  for (auto it = file.beginName(); it != file.endName(); ++it) names.push_back(it.gridName());
  EXPECT_EQ(names, (std::vector<std::string>{"tsdf", "weight"}));
  const auto tsdf = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tsdf"));
  const auto weight = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("weight"));
  file.close();
  ASSERT_TRUE(tsdf);
  ASSERT_TRUE(weight);
  EXPECT_EQ(tsdf->getGridClass(), openvdb::GRID_LEVEL_SET);
  EXPECT_EQ(weight->getGridClass(), openvdb::GRID_UNKNOWN);
  EXPECT_FLOAT_EQ(tsdf->background(), static_cast<float>(kTruncation));
  EXPECT_EQ(weight->background(), 0.0f);
  EXPECT_FLOAT_EQ(tsdf->metaValue<float>("truncation_m"), static_cast<float>(kTruncation));
  for (const auto& grid : {tsdf, weight}) {
    EXPECT_TRUE(grid->transform().isLinear());
    EXPECT_TRUE(grid->hasUniformVoxels());
    EXPECT_DOUBLE_EQ(grid->voxelSize()[0], kVoxel);
    // Voxel g's centre is at g * voxel size: no half-voxel shift, no rotation.
    const openvdb::Vec3d p = grid->indexToWorld(openvdb::Coord(-3, 5, 7));
    EXPECT_NEAR(p.x(), -0.03, 1e-12);
    EXPECT_NEAR(p.y(), 0.05, 1e-12);
    EXPECT_NEAR(p.z(), 0.07, 1e-12);
    EXPECT_EQ(grid->activeVoxelCount(), 64u + 512u);
    EXPECT_EQ(grid->tree().leafCount(), 2u);
  }
  const auto t = tsdf->getConstAccessor();
  const auto w = weight->getConstAccessor();
  for (int b = 0; b < 2; ++b)
    for (int z = 0; z < 8; ++z)
      for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
          const Eigen::Vector3i g = bricks[b].origin + Eigen::Vector3i(x, y, z);
          const openvdb::Coord c(g.x(), g.y(), g.z());
          const int i = local_index(x, y, z);
          const bool observed = bricks[b].weight[i] > 0.0f;
          EXPECT_EQ(t.isValueOn(c), observed) << c;
          EXPECT_EQ(t.getValue(c), observed ? bricks[b].sdf_m[i] : static_cast<float>(kTruncation));
          EXPECT_EQ(w.getValue(c), bricks[b].weight[i]) << c;
        }
  EXPECT_FALSE(t.isValueOn(openvdb::Coord(64, 64, 64)));  // the unobserved brick wrote nothing
}

TEST(Vdb, ReadBackGivesTheObservedBricksInOrder) {
  testing::ScratchDir dir;
  const std::vector<VolumeBrick> bricks = sample_bricks();
  write_volume_vdb(dir.file("volume.vdb"), view_of(bricks));
  const VolumeData data = read_volume_vdb(dir.file("volume.vdb"));
  EXPECT_DOUBLE_EQ(data.voxel_size_m, kVoxel);
  EXPECT_FLOAT_EQ(static_cast<float>(data.truncation_m), static_cast<float>(kTruncation));
  ASSERT_EQ(data.bricks.size(), 2u);
  // Ordered by (z, y, x): brick 0 (z = -16) first.
  EXPECT_EQ(data.bricks[0].origin, bricks[0].origin);
  EXPECT_EQ(data.bricks[1].origin, bricks[1].origin);
  EXPECT_EQ(data.bricks[1].sdf_m, bricks[1].sdf_m);
  EXPECT_EQ(data.bricks[1].weight, bricks[1].weight);
  for (int i = 0; i < kBrickVoxels; ++i) {
    EXPECT_EQ(data.bricks[0].weight[i], bricks[0].weight[i]);
    EXPECT_EQ(data.bricks[0].sdf_m[i], bricks[0].sdf_m[i]);  // unobserved: truncation both
  }
}

// With colour: the grids Cd (RGB in [0, 1]) and colour_weight on the observed voxels that have
// colour, exactly as OpenVDB reads them, and the bytes and weights back exactly; an observed voxel
// without colour stays uncoloured, and a colour on an unobserved voxel is not written.
TEST(Vdb, ColourIsWrittenAsCdAndColourWeightAndReadBackExactly) {
  testing::ScratchDir dir;
  std::vector<VolumeBrick> bricks = sample_bricks();
  for (int i = 0; i < kBrickVoxels; ++i) {
    if (i % 3 == 0) continue;  // observed without colour
    bricks[1].colour[i] = Rgb8{static_cast<std::uint8_t>(i % 256), static_cast<std::uint8_t>(255 - i % 256),
                               static_cast<std::uint8_t>((7 * i) % 256)};
    bricks[1].colour_weight[i] = static_cast<std::uint8_t>(1 + i % 16);
  }
  bricks[2].colour[0] = Rgb8{1, 2, 3};  // the unobserved brick: not written
  bricks[2].colour_weight[0] = 5;
  VolumeView view = view_of(bricks);
  view.has_colour = true;
  write_volume_vdb(dir.file("volume.vdb"), view);

  openvdb::initialize();
  openvdb::io::File file(dir.file("volume.vdb"));
  file.open();
  std::vector<std::string> names;
  for (auto it = file.beginName(); it != file.endName(); ++it) names.push_back(it.gridName());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"Cd", "colour_weight", "tsdf", "weight"}));
  const auto cd = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("Cd"));
  file.close();
  ASSERT_TRUE(cd);
  EXPECT_EQ(cd->activeVoxelCount(), 512u - 171u);  // brick 1's voxels with colour
  const openvdb::Vec3s c = cd->getConstAccessor().getValue(openvdb::Coord(-8 + 1, -8, 0));
  EXPECT_FLOAT_EQ(c.x(), 1.0f / 255.0f);
  EXPECT_FLOAT_EQ(c.y(), 254.0f / 255.0f);
  EXPECT_FLOAT_EQ(c.z(), 7.0f / 255.0f);

  const VolumeData data = read_volume_vdb(dir.file("volume.vdb"));
  EXPECT_TRUE(data.has_colour);
  ASSERT_EQ(data.bricks.size(), 2u);
  EXPECT_EQ(data.bricks[1].colour, bricks[1].colour);
  EXPECT_EQ(data.bricks[1].colour_weight, bricks[1].colour_weight);
  for (int i = 0; i < kBrickVoxels; ++i) EXPECT_EQ(data.bricks[0].colour_weight[i], 0) << i;

  // Without colour the file is the one of a volume that never had any.
  view.has_colour = false;
  write_volume_vdb(dir.file("plain.vdb"), view);
  write_volume_vdb(dir.file("never.vdb"), view_of(sample_bricks()));
  const auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(dir.file("plain.vdb")), bytes(dir.file("never.vdb")));
  EXPECT_FALSE(read_volume_vdb(dir.file("plain.vdb")).has_colour);
}

// A file with one of the two colour grids and not the other is damaged.
TEST(Vdb, HalfTheColourGridsIsAnErrorNamingTheFile) {
  testing::ScratchDir dir;
  openvdb::initialize();
  openvdb::FloatGrid::Ptr tsdf = openvdb::FloatGrid::create(0.04f);
  openvdb::FloatGrid::Ptr weight = openvdb::FloatGrid::create(0.0f);
  openvdb::Vec3SGrid::Ptr cd = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
  tsdf->setName("tsdf");
  weight->setName("weight");
  cd->setName("Cd");
  tsdf->tree().setValueOn(openvdb::Coord(1, 2, 3), 0.01f);
  weight->tree().setValueOn(openvdb::Coord(1, 2, 3), 1.0f);
  openvdb::io::File(dir.file("half.vdb")).write(openvdb::GridCPtrVec{tsdf, weight, cd});
  try {
    read_volume_vdb(dir.file("half.vdb"));
    FAIL() << "read a file with Cd and no colour_weight";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(dir.file("half.vdb")), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("colour_weight"), std::string::npos) << e.what();
  }
}

TEST(Vdb, BytesDependOnlyOnTheVoxels) {
  testing::ScratchDir dir;
  const std::vector<VolumeBrick> bricks = sample_bricks();
  write_volume_vdb(dir.file("a.vdb"), view_of(bricks));
  write_volume_vdb(dir.file("b.vdb"), view_of(bricks, /*reversed=*/true));
  const std::string a = testing::read_bytes(dir.file("a.vdb"));
  EXPECT_EQ(a, testing::read_bytes(dir.file("b.vdb")));
  // The UUID is derived from the content: another volume gets another one.
  std::vector<VolumeBrick> other = sample_bricks();
  other[1].weight[0] = 99.0f;
  write_volume_vdb(dir.file("c.vdb"), view_of(other));
  const std::string c = testing::read_bytes(dir.file("c.vdb"));
  ASSERT_GT(a.size(), 57u);
  EXPECT_NE(a.substr(21, 36), c.substr(21, 36));
  EXPECT_EQ(a.substr(21 + 8, 1), "-");
}

TEST(Vdb, EmptyVolumeIsAValidFile) {
  testing::ScratchDir dir;
  VolumeView view;
  view.voxel_size_m = kVoxel;
  view.truncation_m = kTruncation;
  const VdbWriteStats stats = write_volume_vdb(dir.file("empty.vdb"), view);
  EXPECT_EQ(stats.active_voxels, 0u);
  const VolumeData data = read_volume_vdb(dir.file("empty.vdb"));
  EXPECT_TRUE(data.bricks.empty());
  EXPECT_DOUBLE_EQ(data.voxel_size_m, kVoxel);
}

TEST(Vdb, NonFiniteVoxelsAreNotWritten) {
  testing::ScratchDir dir;
  std::vector<VolumeBrick> bricks = sample_bricks();
  bricks[1].sdf_m[3] = std::numeric_limits<float>::quiet_NaN();
  bricks[1].weight[4] = std::numeric_limits<float>::infinity();
  const VdbWriteStats stats = write_volume_vdb(dir.file("v.vdb"), view_of(bricks));
  EXPECT_EQ(stats.active_voxels, 64u + 510u);
}

TEST(Vdb, ErrorsNameTheFile) {
  testing::ScratchDir dir;
  const std::vector<VolumeBrick> bricks = sample_bricks();
  const std::string unwritable = dir.file("no/such/folder/volume.vdb");
  try {
    write_volume_vdb(unwritable, view_of(bricks));
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kFailure);
    EXPECT_NE(std::string(e.what()).find(unwritable), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
  std::vector<VolumeBrick> bad = sample_bricks();
  bad[0].origin.x() = 3;
  EXPECT_THROW(write_volume_vdb(dir.file("bad.vdb"), view_of(bad)), Error);
  bad = sample_bricks();
  bad[1].origin = bad[0].origin;
  EXPECT_THROW(write_volume_vdb(dir.file("bad.vdb"), view_of(bad)), Error);
  VolumeView zero = view_of(bricks);
  zero.voxel_size_m = 0.0;
  EXPECT_THROW(write_volume_vdb(dir.file("bad.vdb"), zero), Error);

  auto expect_input_error = [](const std::string& path, const std::string& needle) {
    try {
      read_volume_vdb(path);
      ADD_FAILURE() << "expected an error for " << path;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kBadInput);
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  };
  expect_input_error(dir.file("missing.vdb"), "cannot read");
  testing::write_text(dir.file("garbage.vdb"), "not a vdb file at all");
  expect_input_error(dir.file("garbage.vdb"), "cannot read");
  // A valid OpenVDB file without the weight grid.
  openvdb::initialize();
  openvdb::FloatGrid::Ptr only = openvdb::FloatGrid::create(0.04f);
  only->setName("tsdf");
  openvdb::io::File(dir.file("tsdf_only.vdb")).write({only});
  expect_input_error(dir.file("tsdf_only.vdb"), "weight");
}

}  // namespace
}  // namespace aoscan
