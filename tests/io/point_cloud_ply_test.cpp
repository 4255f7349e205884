/// @file point_cloud_ply_test.cpp
/// @brief Tests for src/io/point_cloud_ply.h: the exact header and layout, exact round trips
/// through read_ply() with and without normals, and the count check.
#include "io/point_cloud_ply.h"

#include <cmath>
#include <functional>
#include <random>

#include <gtest/gtest.h>

#include "core/status.h"
#include "io/ply.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::error_message;
using testing::read_bytes;
using testing::ScratchDir;

/// Points of every magnitude (and their normals), the same on every run.
void cloud(std::size_t n, std::vector<Eigen::Vector3f>& points,
           std::vector<Eigen::Vector3f>& normals) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> e(-20, 20);
  for (std::size_t i = 0; i < n; ++i) {
    points.emplace_back(std::ldexp(u(rng), e(rng)), std::ldexp(u(rng), e(rng)), u(rng) * 50.0f);
    normals.push_back(Eigen::Vector3f(u(rng), u(rng), u(rng)).normalized());
  }
}

TEST(PointCloudPly, HeaderIsExact) {
  EXPECT_EQ(point_cloud_ply_header(3, false),
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
            "property float y\nproperty float z\nend_header\n");
  EXPECT_EQ(point_cloud_ply_header(12345678901LL, true),
            "ply\nformat binary_little_endian 1.0\nelement vertex 12345678901\nproperty float x\n"
            "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
            "property float nz\nend_header\n");
}

TEST(PointCloudPly, RoundTripsExactlyWithAndWithoutNormals) {
  ScratchDir dir;
  std::vector<Eigen::Vector3f> points, normals;
  cloud(100000, points, normals);  // more than one write buffer
  for (const bool with_normals : {true, false}) {
    const std::string path = dir.file(with_normals ? "n.ply" : "p.ply");
    PointCloudPlyWriter writer(path, static_cast<std::int64_t>(points.size()), with_normals);
    for (std::size_t i = 0; i < points.size(); ++i) writer.add(points[i], normals[i]);
    writer.close();
    const std::string bytes = read_bytes(path);
    const std::string header =
        point_cloud_ply_header(static_cast<std::int64_t>(points.size()), with_normals);
    ASSERT_EQ(bytes.size(), header.size() + points.size() * (with_normals ? 24 : 12));
    EXPECT_EQ(bytes.substr(0, header.size()), header);
    const TriangleMesh back = read_ply(path);
    ASSERT_EQ(back.vertices.size(), points.size());
    EXPECT_TRUE(back.faces.empty());
    EXPECT_EQ(back.normals.size(), with_normals ? points.size() : 0u);
    for (std::size_t i = 0; i < points.size(); ++i) {
      ASSERT_EQ(back.vertices[i], points[i]) << i;
      if (with_normals) {
        ASSERT_EQ(back.normals[i], normals[i]) << i;
      }
    }
  }
}

TEST(PointCloudPly, AnEmptyCloudIsAValidFile) {
  ScratchDir dir;
  PointCloudPlyWriter writer(dir.file("e.ply"), 0, true);
  writer.close();
  EXPECT_EQ(read_bytes(dir.file("e.ply")), point_cloud_ply_header(0, true));
  EXPECT_TRUE(read_ply(dir.file("e.ply")).vertices.empty());
}

TEST(PointCloudPly, ThePointCountMustMatchTheHeader) {
  ScratchDir dir;
  const std::string path = dir.file("c.ply");
  EXPECT_NE(error_message([&] {
              PointCloudPlyWriter writer(path, 2, false);
              writer.add({1, 2, 3});
              writer.close();
            }).find(path + ": 1 points written, 2 announced"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              PointCloudPlyWriter writer(path, 1, false);
              writer.add({1, 2, 3});
              writer.add({1, 2, 3});
            }).find(path + ": more points than the 1 the header announces"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              PointCloudPlyWriter(dir.file("absent/c.ply"), 1, false);
            }).find("absent/c.ply: cannot write"),
            std::string::npos);
  EXPECT_NE(error_message([&] { PointCloudPlyWriter(path, -1, false); }).find("negative"),
            std::string::npos);
}

}  // namespace
}  // namespace aoscan
