// The scratch files of `aoscan scans` and the budgeted scan cache: exact round trips, damaged
// files named, least recently used scans dropped first and scans in use never, a dropped scan
// read into by the next of its size.
#include "pipeline/scan_store.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/status.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;
using testing::ScratchDir;

/// An 8 x 4 equirectangular scan with points at the pixels where (x + y) % 3 != 0, every value
/// distinct.
ScanAo make_scan(const std::string& name) {
  ScanAo s;
  s.map.name = name;
  s.map.camera = ScanCamera::make_equirectangular(4);
  s.map.T_world_scanner =
      Pose(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix(),
           Eigen::Vector3d(1.5, -2.0, 0.25));
  const int w = s.map.camera.width, h = s.map.camera.height;
  s.map.points.resize(w, h, Eigen::Vector3f::Zero());
  s.map.normals.resize(w, h, Eigen::Vector3f::Zero());
  s.ssao.resize(w, h, 1.0f);
  s.border_px.resize(w, h, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if ((x + y) % 3 == 0) continue;
      const float k = static_cast<float>(y * w + x);
      s.map.points(x, y) = Eigen::Vector3f(1.0f + k, 0.5f * k, -0.25f * k);
      s.map.normals(x, y) = Eigen::Vector3f(0.0f, 0.6f, -0.8f);
      s.ssao(x, y) = 0.01f * k;
      s.border_px(x, y) = 3.0f * k;
    }
  s.map.noise.log_lo = -0.5f;
  s.map.noise.bin_per_log = 3.25f;
  for (int b = 0; b < ScanNoise::kBins; ++b) s.map.noise.sigma_m[b] = 1e-3f * (1.0f + 0.5f * b);
  return s;
}

template <typename T>
void expect_same(const Image<T>& a, const Image<T>& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) EXPECT_EQ(a(x, y), b(x, y)) << x << ", " << y;
}

TEST(ScanStore, AScanFileGivesBackTheScanAndItsDescriptionExactly) {
  ScratchDir dir;
  const ScanAo scan = make_scan("hall-2");
  const ScanInfo info = describe_scan(scan, "hall.ptx", 17);
  EXPECT_EQ(info.points, 32 - 11);  // 11 of the 32 pixels have (x + y) % 3 == 0
  EXPECT_EQ(info.loaded_bytes(), 32u * 32u);
  const std::string file = dir.file("scan-000001.bin");
  write_scan_file(file, info, scan);
  ScanAo fewer = scan;  // one point less: 36 bytes less
  fewer.map.points(1, 0) = Eigen::Vector3f::Zero();
  write_scan_file(dir.file("fewer.bin"), describe_scan(fewer, "hall.ptx", 17), fewer);
  EXPECT_EQ(fs::file_size(file) - fs::file_size(dir.file("fewer.bin")), 36u);

  const ScanInfo back = read_scan_info(file);
  EXPECT_EQ(back.name, "hall-2");
  EXPECT_EQ(back.source, "hall.ptx");
  EXPECT_EQ(back.points, info.points);
  EXPECT_EQ(back.skipped, 17);
  EXPECT_EQ(back.max_depth_m, info.max_depth_m);
  EXPECT_EQ(back.world_box.min(), info.world_box.min());
  EXPECT_EQ(back.world_box.max(), info.world_box.max());
  EXPECT_EQ(back.T_world_scanner.matrix(), scan.map.T_world_scanner.matrix());
  EXPECT_EQ(back.camera.projection, ScanProjection::kEquirectangular);
  EXPECT_EQ(back.noise.log_lo, -0.5f);
  EXPECT_EQ(back.noise.bin_per_log, 3.25f);
  EXPECT_EQ(back.noise.sigma_m, scan.map.noise.sigma_m);

  ScanAo loaded;
  read_scan_file(file, loaded);
  EXPECT_EQ(loaded.map.name, "hall-2");
  expect_same(loaded.map.points, scan.map.points);
  expect_same(loaded.map.normals, scan.map.normals);
  expect_same(loaded.ssao, scan.ssao);
  expect_same(loaded.border_px, scan.border_px);
  EXPECT_EQ(loaded.map.noise.sigma_m, scan.map.noise.sigma_m);
  EXPECT_EQ(loaded.map.noise.log_lo, scan.map.noise.log_lo);
  EXPECT_EQ(loaded.map.noise.bin_per_log, scan.map.noise.bin_per_log);

  Image<float> mvao(8, 4, 1.0f);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x)
      if (scan.map.has_point(x, y)) mvao(x, y) = 0.5f + 0.01f * static_cast<float>(x - y);
  write_mvao_file(dir.file("mvao-000001.bin"), scan.map, mvao, 9);
  EXPECT_EQ(mvao_file_shared(dir.file("mvao-000001.bin"), info.points), 9);
  EXPECT_FALSE(mvao_file_shared(dir.file("mvao-000001.bin"), info.points + 1));
  Image<float> mvao_back;
  EXPECT_EQ(read_mvao_file(dir.file("mvao-000001.bin"), loaded.map, mvao_back), 9);
  expect_same(mvao_back, mvao);
}

TEST(ScanStore, DamagedOrMissingFilesAreErrorsNamingTheFile) {
  ScratchDir dir;
  const ScanAo scan = make_scan("a");
  const std::string file = dir.file("scan-000000.bin");
  write_scan_file(file, describe_scan(scan, "a.ply", 0), scan);
  const auto message_of = [](const auto& call) {
    try {
      call();
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kFailure);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  fs::resize_file(file, fs::file_size(file) - 1);
  EXPECT_EQ(message_of([&] { read_scan_info(file); }),
            file + ": damaged scratch file: its size does not match its header (21 points)");
  ScanAo loaded;
  EXPECT_EQ(message_of([&] { read_scan_file(file, loaded); }),
            file + ": damaged scratch file: it ends early");
  EXPECT_EQ(message_of([&] { read_scan_info(dir.file("absent.bin")); }),
            dir.file("absent.bin") + ": damaged scratch file: cannot open it");
  { std::ofstream(dir.file("other.bin")) << "AOSCAN-VALS 1\n"; }
  EXPECT_EQ(message_of([&] { read_scan_info(dir.file("other.bin")); }),
            dir.file("other.bin") + ": damaged scratch file: it is not a scratch file of this version");
  EXPECT_FALSE(mvao_file_shared(dir.file("absent.bin"), 21));

  // A noise table that no scan could have measured.
  ScanAo bad = scan;
  bad.map.noise.sigma_m[3] = -1.0f;
  write_scan_file(file, describe_scan(bad, "a.ply", 0), bad);
  EXPECT_EQ(message_of([&] { read_scan_info(file); }),
            file + ": damaged scratch file: its noise table is damaged");
}

TEST(ScanCache, DropsTheLeastRecentlyUsedScansThatNobodyHolds) {
  std::vector<int> loaded;
  ScanCache cache(300, [&loaded](std::uint64_t key, ScanAo& scan) {
    loaded.push_back(static_cast<int>(key));
    scan.map.name = std::to_string(key);
  });
  EXPECT_EQ(cache.get(0, 100)->map.name, "0");
  cache.get(1, 100);
  cache.get(2, 100);
  cache.get(0, 100);  // held: no load, and 0 is now the most recently used
  EXPECT_EQ(cache.loads(), 3);
  cache.get(3, 100);  // drops 1, the least recently used
  EXPECT_EQ(cache.held_bytes(), 300u);
  cache.get(0, 100);
  EXPECT_EQ(cache.loads(), 4);
  cache.get(1, 100);  // drops 2
  EXPECT_EQ(loaded, (std::vector<int>{0, 1, 2, 3, 1}));
  {
    // A scan in use stays even when it is the least recently used; the next one goes instead.
    const std::shared_ptr<const ScanAo> three = cache.get(3, 100);
    cache.get(0, 100);
    cache.get(1, 100);
    cache.get(4, 100);  // 3 is in use: 0 goes
    EXPECT_EQ(loaded.back(), 4);
    cache.get(3, 100);
    EXPECT_EQ(cache.loads(), 6);
  }
  // A scan computed elsewhere is kept when it fits after dropping what can be dropped.
  auto made = std::make_shared<const ScanAo>();
  cache.put(7, made, 200);
  EXPECT_EQ(cache.held_bytes(), 300u);
  cache.get(7, 200);
  EXPECT_EQ(cache.loads(), 6);
  cache.put(8, std::make_shared<const ScanAo>(), 400);  // larger than the budget: not kept,
  EXPECT_EQ(cache.held_bytes(), 300u);                   // and nothing dropped for it
  cache.set_budget(200);
  EXPECT_EQ(cache.held_bytes(), 200u);  // 3 goes; 7 stays, held by `made`
  made.reset();
  cache.set_budget(100);
  EXPECT_EQ(cache.held_bytes(), 0u);
}

TEST(ScanCache, AScanOfTheSameSizeIsReadIntoTheOneItDropsAndKeepsNothingOfIt) {
  ScratchDir dir;
  // Two scans of one map size with points at different pixels: the second must come back with
  // none of the first's points, normals, SSAO or border distances where it has no point.
  const ScanAo a = make_scan("a");
  ScanAo b = make_scan("b");
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x)
      if ((x + y) % 2 == 0) {
        b.map.points(x, y) = Eigen::Vector3f::Zero();
        b.map.normals(x, y) = Eigen::Vector3f::Zero();
        b.ssao(x, y) = 1.0f;
        b.border_px(x, y) = 0.0f;
      }
  b.map.T_world_scanner = Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 1.0, 0.0));
  write_scan_file(dir.file("a.bin"), describe_scan(a, "a.ply", 0), a);
  write_scan_file(dir.file("b.bin"), describe_scan(b, "b.ply", 0), b);
  const std::size_t bytes = describe_scan(a, "a.ply", 0).loaded_bytes();
  // The loader notes what it is given to read into: a new scan (no name) or a dropped one.
  std::vector<std::string> given;
  const ScanCache::Loader load = [&dir, &given](std::uint64_t key, ScanAo& scan) {
    given.push_back(scan.map.name);
    read_scan_file(dir.file(key == 0 ? "a.bin" : "b.bin"), scan);
  };
  ScanCache cache(bytes, load);
  cache.get(0, bytes);
  const std::shared_ptr<const ScanAo> back = cache.get(1, bytes);  // drops a, reads b into it
  EXPECT_EQ(given, (std::vector<std::string>{"", "a"}));
  EXPECT_EQ(cache.loads(), 2);
  ScanAo fresh;
  read_scan_file(dir.file("b.bin"), fresh);
  EXPECT_EQ(back->map.name, "b");
  EXPECT_EQ(back->map.T_world_scanner.matrix(), fresh.map.T_world_scanner.matrix());
  expect_same(back->map.points, fresh.map.points);
  expect_same(back->map.normals, fresh.map.normals);
  expect_same(back->ssao, fresh.ssao);
  expect_same(back->border_px, fresh.border_px);
  expect_same(back->map.points, b.map.points);

  // A scan in use is never read into, nor one kept with put() (it is const: it is freed when
  // dropped).
  given.clear();
  ScanCache roomy(2 * bytes, load);
  bool put_freed = false;
  roomy.put(5,
            std::shared_ptr<const ScanAo>(new ScanAo(a),
                                          [&put_freed](const ScanAo* p) {
                                            put_freed = true;
                                            delete p;
                                          }),
            bytes);
  const std::shared_ptr<const ScanAo> one = roomy.get(0, bytes);
  const std::shared_ptr<const ScanAo> two = roomy.get(1, bytes);  // 0 is held: 5 goes
  EXPECT_TRUE(put_freed);
  EXPECT_EQ(given, (std::vector<std::string>{"", ""}));
  EXPECT_EQ(one->map.name, "a");
  EXPECT_EQ(two->map.name, "b");
}

}  // namespace
}  // namespace aoscan
