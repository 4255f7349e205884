/// @file point_maps_test.cpp
/// @brief Tests for src/geometry/point_maps.cpp on analytic scenes: vertex and normal maps of
/// planes and a sphere, 2x2 downsampling.
#include <cmath>
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "core/status.h"
#include "geometry/point_maps.h"
#include "support/prep_test_util.h"

namespace aoscan {
namespace {

const Intrinsics kKinect{640, 480, 585.0, 585.0, 320.0, 240.0};

using test::angle;
using test::kPlanes;
using test::Plane;

TEST(VertexNormalMaps, PlaneVerticesLieOnThePlaneAndNormalsEqualItsNormal) {
  for (const Plane& plane : kPlanes) {
    const Image<float> depth = test::render_plane(kKinect, plane.n, plane.d);
    Image<Eigen::Vector3f> vertices, normals;
    compute_vertex_map(depth, kKinect, vertices);
    compute_normal_map(vertices, 1.0f, normals);
    // The plane's normal oriented towards the camera: n . p = d < 0 for points in front.
    const Eigen::Vector3d facing = plane.d < 0 ? plane.n : -plane.n;
    double worst_distance = 0, worst_angle = 0;
    int normals_checked = 0;
    for (int y = 0; y < kKinect.height; ++y)
      for (int x = 0; x < kKinect.width; ++x) {
        const Eigen::Vector3d v = vertices(x, y).cast<double>();
        if (depth(x, y) == 0.0f) {
          EXPECT_EQ(vertices(x, y), Eigen::Vector3f::Zero());
          continue;
        }
        EXPECT_EQ(vertices(x, y),
                  kKinect.unproject(static_cast<float>(x), static_cast<float>(y), depth(x, y)));
        worst_distance = std::max(worst_distance, std::abs(plane.n.dot(v) - plane.d));
        if (x + 1 < kKinect.width && y + 1 < kKinect.height) {
          ASSERT_NEAR(normals(x, y).norm(), 1.0f, 1e-6f) << x << "," << y;
          worst_angle = std::max(worst_angle, angle(normals(x, y).cast<double>(), facing));
          ++normals_checked;
        } else {
          EXPECT_EQ(normals(x, y), Eigen::Vector3f::Zero());
        }
      }
    EXPECT_EQ(normals_checked, (kKinect.width - 1) * (kKinect.height - 1));
    EXPECT_LT(worst_distance, 1e-5);
    // Float vertices carry about 1 ulp of z (1.2e-7 z) of error; over the pixel spacing z / f this
    // tilts a forward-difference normal by up to about 2 f ulp / z ~ 1.4e-4 rad for f = 585.
    EXPECT_LT(worst_angle, 3e-4) << plane.n.transpose();
  }
}

TEST(VertexNormalMaps, SphereNormalsPointAwayFromTheCentre) {
  const Eigen::Vector3d centre(0.1, -0.05, 2.0);
  const double radius = 0.5;
  const Image<float> depth = test::render_sphere(kKinect, centre, radius);
  Image<Eigen::Vector3f> vertices, normals;
  compute_vertex_map(depth, kKinect, vertices);
  compute_normal_map(vertices, 0.05f, normals);
  double worst_pixel = 0, worst_triangle = 0, worst_radius = 0;
  int checked = 0;
  for (int y = 0; y < kKinect.height; ++y)
    for (int x = 0; x < kKinect.width; ++x) {
      if (depth(x, y) == 0.0f) continue;
      const Eigen::Vector3d v = vertices(x, y).cast<double>();
      worst_radius = std::max(worst_radius, std::abs((v - centre).norm() - radius));
      const Eigen::Vector3d expected = (v - centre) / radius;
      // Restrict to where the surface faces the camera within 60 degrees (no grazing limb).
      if (expected.dot(-v.normalized()) < 0.5 || normals(x, y).isZero()) continue;
      const Eigen::Vector3d n = normals(x, y).cast<double>();
      worst_pixel = std::max(worst_pixel, angle(n, expected));
      // The forward-difference normal is the normal of the plane through v and its right and
      // down neighbours; on a sphere that plane's normal points from the centre to the
      // triangle's circumcentre, which makes an exact reference up to float rounding.
      const Eigen::Vector3d u = vertices(x + 1, y).cast<double>() - v;
      const Eigen::Vector3d w = vertices(x, y + 1).cast<double>() - v;
      const Eigen::Vector3d uw = u.cross(w);
      const Eigen::Vector3d circumcentre =
          v + (u.squaredNorm() * w - w.squaredNorm() * u).cross(uw) / (2.0 * uw.squaredNorm());
      worst_triangle = std::max(worst_triangle, angle(n, (circumcentre - centre).normalized()));
      ++checked;
    }
  EXPECT_GT(checked, 20000);
  EXPECT_LT(worst_radius, 1e-5);
  // At the pixel itself the normal is off by about half a pixel footprint over the radius,
  // 0.7 (z / f) / r / cos(60 deg) ~ 0.01 rad at 2 m.
  EXPECT_LT(worst_pixel, 0.015);
  EXPECT_LT(worst_triangle, 3e-4);  // float rounding only, as for the plane
}

TEST(VertexNormalMaps, NoNormalAcrossJumpsHolesOrAtTheLastRowAndColumn) {
  Image<float> depth(8, 6, 1.0f);
  for (int y = 0; y < 6; ++y)
    for (int x = 5; x < 8; ++x) depth(x, y) = 1.2f;  // 20 cm step between x = 4 and x = 5
  depth(2, 2) = 0.0f;                                // a hole
  const Intrinsics k{8, 6, 10.0, 10.0, 3.5, 2.5};
  Image<Eigen::Vector3f> vertices, normals;
  compute_vertex_map(depth, k, vertices);
  compute_normal_map(vertices, 0.05f, normals);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) {
      const bool none = x == 7 || y == 5 || x == 4 ||                // border, step
                        (x == 2 && y == 2) || (x == 1 && y == 2) ||  // hole, left of the hole
                        (x == 2 && y == 1);                          // above the hole
      if (none) {
        EXPECT_EQ(normals(x, y), Eigen::Vector3f::Zero()) << x << "," << y;
      } else {
        EXPECT_NEAR((normals(x, y) - Eigen::Vector3f(0, 0, -1)).norm(), 0.0f, 1e-6f)
            << x << "," << y;
      }
    }
  // A larger threshold keeps the step's normals (they are then slanted, still unit length).
  compute_normal_map(vertices, 0.5f, normals);
  EXPECT_NEAR(normals(4, 0).norm(), 1.0f, 1e-6f);
  EXPECT_LT(normals(4, 0).dot(vertices(4, 0)), 0.0f);
}

TEST(Downsample, AveragesOnlyTheSameSurface) {
  Image<float> depth(5, 4, 0.0f);  // odd width: the last column is dropped
  // Block (0, 0): all valid, one far outlier beyond 9 cm of the first value.
  depth(0, 0) = 1.0f;
  depth(1, 0) = 1.02f;
  depth(0, 1) = 1.04f;
  depth(1, 1) = 2.0f;
  // Block (1, 0): first valid in raster order is the bottom-left one.
  depth(3, 1) = 3.0f;
  depth(2, 1) = 2.95f;
  // Block (0, 1) stays empty; block (1, 1) is constant.
  for (int y = 2; y < 4; ++y)
    for (int x = 2; x < 4; ++x) depth(x, y) = 1.7f;
  depth(4, 0) = 9.0f;  // dropped column
  Image<float> out;
  downsample_depth(depth, 0.09f, out);
  ASSERT_EQ(out.width(), 2);
  ASSERT_EQ(out.height(), 2);
  EXPECT_FLOAT_EQ(out(0, 0), (1.0f + 1.02f + 1.04f) / 3.0f);
  EXPECT_FLOAT_EQ(out(1, 0), (2.95f + 3.0f) / 2.0f);
  EXPECT_EQ(out(0, 1), 0.0f);
  EXPECT_EQ(out(1, 1), 1.7f);  // exactly
}

}  // namespace
}  // namespace aoscan

namespace aoscan {
namespace {

/// Largest absolute component difference of two vector maps, and whether their zero (invalid)
/// pixels coincide.
float max_difference(const Image<Eigen::Vector3f>& a, const Image<Eigen::Vector3f>& b,
                     bool& same_zeros) {
  float worst = 0.0f;
  same_zeros = a.width() == b.width() && a.height() == b.height();
  for (int y = 0; same_zeros && y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      if (a(x, y).isZero() != b(x, y).isZero()) same_zeros = false;
      worst = std::max(worst, (a(x, y) - b(x, y)).cwiseAbs().maxCoeff());
    }
  return worst;
}

TEST(PointMaps, FusedFastMapsEqualVertexAndNormalMapReferences) {
  // Random patches (depth steps above and below the jump, holes, noise), several sizes including
  // widths that are not a multiple of eight and a single row / column, and a slanted plane.
  struct Case {
    Image<float> depth;
    Intrinsics k;
  };
  std::vector<Case> cases;
  const int sizes[][2] = {{640, 480}, {37, 23}, {9, 9}, {8, 3}, {1, 5}, {5, 1}};
  std::uint32_t seed = 3;
  for (const auto& s : sizes) {
    const Intrinsics k{
        s[0], s[1], 585.0 * s[0] / 640, 585.0 * s[0] / 640, s[0] / 2.0 - 0.3, s[1] / 2.0 + 0.2};
    cases.push_back({test::random_depth(s[0], s[1], seed++), k});
  }
  const Intrinsics kinect = test::redkitchen_intrinsics();
  cases.push_back(
      {test::render_plane(kinect, Eigen::Vector3d(0.3, -0.2, -1).normalized(), -1.5), kinect});
  for (const Case& c : cases) {
    SCOPED_TRACE(std::to_string(c.k.width) + "x" + std::to_string(c.k.height));
    PointMaps fast;  // reused: the second jump overwrites the first one's maps in place
    for (float jump : {0.1f, 0.01f}) {
      Image<Eigen::Vector3f> vertices, normals;
      compute_vertex_map(c.depth, c.k, vertices);
      compute_normal_map(vertices, jump, normals);
      compute_point_maps(c.depth, c.k, jump, fast);
      bool same_zeros = false;
      // Bit for bit in the default build; 1e-6 allows FMA contraction of the references.
      EXPECT_LE(max_difference(fast.vertices, vertices, same_zeros), 1e-6f);
      EXPECT_TRUE(same_zeros);
      EXPECT_LE(max_difference(fast.normals, normals, same_zeros), 1e-6f);
      EXPECT_TRUE(same_zeros);
      EXPECT_EQ(fast.intrinsics.width, c.k.width);
#if !defined(__FMA__)
      EXPECT_TRUE(fast.vertices == vertices);
      EXPECT_TRUE(fast.normals == normals);
#endif
    }
  }
}

}  // namespace
}  // namespace aoscan
