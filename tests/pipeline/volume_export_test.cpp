// Tests for src/pipeline/volume_export.cpp and the session's save_volume: a fused analytic plane
// written to volume.vdb and read back by OpenVDB with exact voxel values, the round trip into a
// TsdfVolume, and the session's outputs and errors.
#include "pipeline/volume_export.h"

#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <nlohmann/json.hpp>

#include "capture/synth_source.h"
#include "core/status.h"
#include "fusion/tsdf/marching_cubes.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "pipeline/session.h"
#include "support/scratch_dir.h"
#include "support/test_scenes.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

const Intrinsics kKinect{640, 480, 585.0, 585.0, 320.0, 240.0};
constexpr double kPlaneDepthM = 1.0;

/// A fronto-parallel plane at kPlaneDepthM fused once from the identity pose.
TsdfVolume fused_plane() {
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), kPlaneDepthM});
  Image<float> depth;
  test::render(scene, kKinect, Pose::identity(), depth);
  integrator.integrate(volume, depth, kKinect, Pose::identity());
  return volume;
}

TEST(VolumeExport, FusedPlaneHasExactVoxelsInOpenVdb) {
  aoscan::testing::ScratchDir scratch;
  const TsdfVolume volume = fused_plane();
  const fs::path dir = scratch.folder("plane");
  const std::string path = (dir / "volume.vdb").string();
  const VdbWriteStats stats = write_volume(path, volume);

  openvdb::initialize();
  openvdb::io::File file(path);
  file.open();
  const auto tsdf = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tsdf"));
  const auto weight = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("weight"));
  file.close();
  ASSERT_TRUE(tsdf && weight);
  EXPECT_DOUBLE_EQ(tsdf->voxelSize()[0], FusionConfig{}.voxel_size_m);
  EXPECT_FLOAT_EQ(tsdf->background(), volume.truncation_m());

  // Every observed voxel of the volume is active in the file with the same values, and nothing
  // else is.
  const float truncation = volume.truncation_m();
  std::size_t observed = 0, checked_band = 0;
  const auto t = tsdf->getConstAccessor();
  const auto w = weight->getConstAccessor();
  for (int b = 0; b < volume.block_count(); ++b) {
    const Eigen::Vector3i base = volume.block_coord(b) * kBlockSize;
    for (int z = 0; z < kBlockSize; ++z)
      for (int y = 0; y < kBlockSize; ++y)
        for (int x = 0; x < kBlockSize; ++x) {
          const Voxel& v = volume.block(b).voxels[voxel_index(x, y, z)];
          const Eigen::Vector3i g = base + Eigen::Vector3i(x, y, z);
          const openvdb::Coord c(g.x(), g.y(), g.z());
          ASSERT_EQ(t.isValueOn(c), v.count > 0) << c;
          if (v.count == 0) continue;
          ++observed;
          EXPECT_EQ(t.getValue(c), v.tsdf() * truncation) << c;
          EXPECT_EQ(w.getValue(c), 1.0f) << c;  // one frame
          // The analytic projective distance of a frontal plane: depth - z, capped at +truncation.
          const openvdb::Vec3d p = tsdf->indexToWorld(c);
          const double expected = std::min<double>(truncation, kPlaneDepthM - p.z());
          EXPECT_NEAR(t.getValue(c), expected, 2e-6) << c;
          if (std::abs(kPlaneDepthM - p.z()) < truncation) ++checked_band;
        }
  }
  EXPECT_EQ(static_cast<std::size_t>(tsdf->activeVoxelCount()), observed);
  EXPECT_EQ(stats.active_voxels, observed);
  EXPECT_GT(checked_band, 100000u);
}

TEST(VolumeExport, ReadBackVolumeMeshesLikeTheOriginal) {
  aoscan::testing::ScratchDir scratch;
  const TsdfVolume volume = fused_plane();
  const fs::path dir = scratch.folder("roundtrip");
  const std::string path = (dir / "volume.vdb").string();
  write_volume(path, volume);
  TsdfVolume loaded{FusionConfig{}};
  load_volume(read_volume_vdb(path), loaded);
  const TriangleMesh a = extract_mesh(volume, 1.0f);
  const TriangleMesh b = extract_mesh(loaded, 1.0f);
  ASSERT_GT(a.faces.size(), 1000u);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.faces, b.faces);
  float worst = 0.0f;
  for (std::size_t i = 0; i < a.vertices.size(); ++i)
    worst = std::max(worst, (a.vertices[i] - b.vertices[i]).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 1e-6f);  // tsdf * truncation / truncation: one float rounding at most

  FusionConfig other;
  other.voxel_size_m = 0.01;
  TsdfVolume wrong_size{other};
  EXPECT_THROW(load_volume(read_volume_vdb(path), wrong_size), Error);
  FusionConfig tiny;
  tiny.max_blocks = 1;
  TsdfVolume too_small{tiny};
  EXPECT_THROW(load_volume(read_volume_vdb(path), too_small), Error);
}

// The colour of a volume goes through volume.vdb and back voxel for voxel (the colour of the
// observed voxels; a volume without colour blocks writes no colour grids).
TEST(VolumeExport, ColourGoesThroughVolumeVdbExactly) {
  aoscan::testing::ScratchDir scratch;
  const TsdfVolume volume = fused_plane();
  ColourVolume colour;
  int painted = 0;
  for (int b = 0; b < volume.block_count(); b += 2) {
    ColourBlock& cb = colour.allocate(b);
    for (int v = 0; v < kBlockVoxels; ++v)
      if (volume.block(b).voxels[v].count > 0 && (v + b) % 5 != 0) {
        cb.voxels[v] = ColourVoxel{static_cast<std::uint8_t>(b % 256), static_cast<std::uint8_t>(v % 256),
                                   static_cast<std::uint8_t>((b + v) % 256),
                                   static_cast<std::uint8_t>(1 + v % 16)};
        ++painted;
      }
  }
  ASSERT_GT(painted, 1000);
  const std::string path = (scratch.folder("colour") / "volume.vdb").string();
  write_volume(path, volume, nullptr, &colour);
  TsdfVolume loaded{FusionConfig{}};
  ColourVolume loaded_colour;
  load_volume(read_volume_vdb(path), loaded, &loaded_colour);
  ASSERT_EQ(loaded.block_count(), volume.block_count());
  int compared = 0;
  for (int b = 0; b < volume.block_count(); ++b) {
    const int l = loaded.find_block(volume.block_coord(b));
    ASSERT_GE(l, 0);
    const ColourBlock* a = colour.block(b);
    const ColourBlock* c = loaded_colour.block(l);
    for (int v = 0; v < kBlockVoxels; ++v) {
      const ColourVoxel want = a != nullptr ? a->voxels[v] : ColourVoxel{};
      const ColourVoxel got = c != nullptr ? c->voxels[v] : ColourVoxel{};
      ASSERT_EQ(std::memcmp(&want, &got, sizeof(ColourVoxel)), 0) << "block " << b << " voxel " << v;
      compared += want.weight > 0;
    }
  }
  EXPECT_EQ(compared, painted);
  // Without colour blocks: no colour grids.
  const ColourVolume none;
  write_volume(path, volume, nullptr, &none);
  EXPECT_FALSE(read_volume_vdb(path).has_colour);
}

TEST(VolumeExport, SessionWritesVolumeAndStats) {
  aoscan::testing::ScratchDir scratch;
  std::unique_ptr<Source> source = open_synth_source("synth:corner?frames=4&width=80&height=60");
  RunOptions options;
  options.out_dir = scratch.folder("session").string();
  options.threads = 1;
  options.save_volume = true;
  std::atomic<bool> stop{false};
  const SessionResult r = run_session(*source, options, stop);
  ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  ASSERT_TRUE(r.volume);
  EXPECT_TRUE(r.volume->written);
  EXPECT_GT(r.volume->active_voxels, 1000u);
  std::ifstream in(fs::path(options.out_dir) / "stats.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["volume"]["written"], true);
  EXPECT_EQ(j["volume"]["active_voxels"].get<std::size_t>(), r.volume->active_voxels);
  EXPECT_EQ(j["volume"]["bytes"].get<std::uintmax_t>(),
            fs::file_size(fs::path(options.out_dir) / "volume.vdb"));
  const VolumeData data = read_volume_vdb((fs::path(options.out_dir) / "volume.vdb").string());
  EXPECT_EQ(data.bricks.size(), r.volume->bricks);
}

TEST(VolumeExport, SessionWithoutSaveVolumeWritesNoVolume) {
  aoscan::testing::ScratchDir scratch;
  std::unique_ptr<Source> source = open_synth_source("synth:corner?frames=2&width=80&height=60");
  RunOptions options;
  options.out_dir = scratch.folder("no_volume").string();
  std::atomic<bool> stop{false};
  const SessionResult r = run_session(*source, options, stop);
  ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  EXPECT_FALSE(fs::exists(fs::path(options.out_dir) / "volume.vdb"));
  std::ifstream in(fs::path(options.out_dir) / "stats.json");
  EXPECT_FALSE(nlohmann::json::parse(in).contains("volume"));
}

TEST(VolumeExport, UnwritableVolumeIsAUsageErrorBeforeTheRun) {
  aoscan::testing::ScratchDir scratch;
  std::unique_ptr<Source> source = open_synth_source("synth:corner?frames=2&width=80&height=60");
  RunOptions options;
  options.out_dir = scratch.folder("blocked").string();
  options.save_volume = true;
  fs::create_directories(fs::path(options.out_dir) / "volume.vdb");  // a folder in the way
  std::atomic<bool> stop{false};
  try {
    run_session(*source, options, stop);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_NE(std::string(e.what()).find("volume.vdb"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(fs::path(options.out_dir) / "stats.json"));  // nothing was run
}

TEST(VolumeExport, ALaterSetUpErrorLeavesNoEmptyVolume) {
  aoscan::testing::ScratchDir scratch;
  std::unique_ptr<Source> source = open_synth_source("synth:corner?frames=2&width=80&height=60");
  RunOptions options;
  options.out_dir = scratch.folder("later_error").string();
  options.save_volume = true;
  const fs::path in_the_way = scratch.folder("later_error_snapshots") / "a_file";
  std::ofstream(in_the_way) << "not a folder\n";
  options.snapshot_dir = in_the_way.string();  // the snapshot folder cannot be made
  std::atomic<bool> stop{false};
  EXPECT_THROW(run_session(*source, options, stop), Error);
  EXPECT_FALSE(fs::exists(fs::path(options.out_dir) / "volume.vdb"));
}

}  // namespace
}  // namespace aoscan
