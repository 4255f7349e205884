/// @file ptx_writer_test.cpp
/// @brief Tests for src/io/ptx_writer.h: what it writes reads back through read_ptx() (io/ptx.h)
/// with the same float bits, the same registration and the same missing cells; the exact text of
/// a small scan; incomplete and overfull scans are errors.
#include "io/ptx_writer.h"

#include <cmath>
#include <functional>
#include <random>

#include <gtest/gtest.h>

#include "core/status.h"
#include "io/ptx.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::error_message;
using testing::read_bytes;
using testing::ScratchDir;

Pose registration(double yaw, const Eigen::Vector3d& t) {
  return Pose(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                  Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix(),
              t);
}

TEST(PtxWriter, TheTextOfASmallScanIsExact) {
  ScratchDir dir;
  PtxWriter writer(dir.file("s.ptx"));
  writer.begin_scan(2, 1, Pose(Eigen::Matrix3d::Identity(), {1.5, -2, 0.25}));
  writer.add({0.1f, -2.0f, 3.0f}, 0.5f);
  writer.add_missing();
  writer.close();
  EXPECT_EQ(read_bytes(dir.file("s.ptx")),
            "2\n1\n1.5 -2 0.25\n1 0 0\n0 1 0\n0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1.5 -2 0.25 1\n"
            "0.1 -2 3 0.5\n0 0 0 0\n");
}

TEST(PtxWriter, ReadsBackBitExactWithItsRegistrations) {
  ScratchDir dir;
  const std::string path = dir.file("set.ptx");
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> e(-12, 8);
  const Pose poses[2] = {registration(0.7, {1.0, 2.0, 1.5}), registration(-2.9, {-3.25, 0.5, 0.0})};
  const int columns[2] = {300, 7}, rows[2] = {200, 3};
  std::vector<Eigen::Vector3f> written[2];
  long long missing[2] = {0, 0};
  PtxWriter writer(path);
  for (int s = 0; s < 2; ++s) {
    writer.begin_scan(columns[s], rows[s], poses[s]);
    for (int i = 0; i < columns[s] * rows[s]; ++i) {
      if (i % 17 == 3) {
        writer.add_missing();
        ++missing[s];
        continue;
      }
      const Eigen::Vector3f p(std::ldexp(u(rng), e(rng)), std::ldexp(u(rng), e(rng)),
                              u(rng) * 90.0f);
      writer.add(p, std::abs(u(rng)));
      written[s].push_back(p);
    }
  }
  writer.close();
  const std::vector<PtxScan> scans = read_ptx(path);
  ASSERT_EQ(scans.size(), 2u);
  for (int s = 0; s < 2; ++s) {
    EXPECT_EQ(scans[s].columns, columns[s]);
    EXPECT_EQ(scans[s].rows, rows[s]);
    EXPECT_EQ(scans[s].missing, missing[s]);
    ASSERT_EQ(scans[s].points.size(), written[s].size());
    for (std::size_t i = 0; i < written[s].size(); ++i)
      ASSERT_EQ(scans[s].points[i], written[s][i]) << s << " " << i;
    EXPECT_LT((scans[s].T_world_scanner.matrix() - poses[s].matrix()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(PtxWriter, AScanMustHaveExactlyItsGridsCells) {
  ScratchDir dir;
  const std::string path = dir.file("bad.ptx");
  EXPECT_NE(error_message([&] {
              PtxWriter writer(path);
              writer.begin_scan(2, 2, Pose());
              writer.add_missing();
              writer.close();
            }).find(path + ": the last scan misses 3 cells"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              PtxWriter writer(path);
              writer.begin_scan(1, 2, Pose());
              writer.add_missing();
              writer.begin_scan(1, 1, Pose());
            }).find(path + ": the previous scan misses 1 cells"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              PtxWriter writer(path);
              writer.begin_scan(1, 1, Pose());
              writer.add({1, 1, 1}, 1.0f);
              writer.add({1, 1, 1}, 1.0f);
            }).find(path + ": a cell beyond the scan's grid"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              PtxWriter writer(path);
              writer.begin_scan(0, 1, Pose());
            }).find("at least one column and one row"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              PtxWriter writer(dir.file("absent/x.ptx"));
            }).find("absent/x.ptx: cannot write"),
            std::string::npos);
}

}  // namespace
}  // namespace aoscan
