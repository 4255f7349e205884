// Tests for src/geometry/scan_camera.cpp and src/geometry/range_map.cpp: projections with exact
// answers, the batched projection against the plain one, the paper's equirectangular map size,
// rasterising clouds, and normals of planes (the windows of compute_range_map_normals(): pixels, a
// metric support, a least number of points).
#include "geometry/scan_camera.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/status.h"
#include "geometry/range_map.h"
#include "support/geometry_reference.h"

namespace aoscan {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(ScanCamera, EquirectangularAxesLandWhereTheConventionSays) {
  const ScanCamera c = ScanCamera::make_equirectangular(100);
  ASSERT_TRUE(c.valid());
  float u = 0, v = 0;
  ASSERT_TRUE(c.project({2.0f, 0.0f, 0.0f}, u, v));  // +x: azimuth 0 on the horizon
  EXPECT_FLOAT_EQ(u, 100.0f);
  EXPECT_FLOAT_EQ(v, 50.0f);
  ASSERT_TRUE(c.project({0.0f, 3.0f, 0.0f}, u, v));  // +y: azimuth pi / 2
  EXPECT_FLOAT_EQ(u, 150.0f);
  ASSERT_TRUE(c.project({0.0f, 0.0f, 1.0f}, u, v));  // the zenith is the top row
  EXPECT_FLOAT_EQ(v, 0.0f);
  EXPECT_FALSE(c.project({0.0f, 0.0f, 0.0f}, u, v));  // the scanner itself
  EXPECT_FLOAT_EQ(c.depth({3.0f, 4.0f, 0.0f}), 5.0f);
  EXPECT_FLOAT_EQ(c.pixels_per_metre_at_1m(), static_cast<float>(200.0 / (2.0 * kPi)));
}

TEST(ScanCamera, EveryEquirectangularPixelCentreMapsBackToItsPixel) {
  const ScanCamera c = ScanCamera::make_equirectangular(37);
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const double phi = (x + 0.5) / c.width * 2.0 * kPi - kPi;
      const double theta = (y + 0.5) / c.height * kPi;
      const Eigen::Vector3f p(static_cast<float>(std::sin(theta) * std::cos(phi) * 4.0),
                              static_cast<float>(std::sin(theta) * std::sin(phi) * 4.0),
                              static_cast<float>(std::cos(theta) * 4.0));
      int px = -1, py = -1;
      ASSERT_TRUE(c.pixel_of(p, px, py));
      EXPECT_EQ(px, x);
      EXPECT_EQ(py, y);
    }
}

TEST(ScanCamera, PinholeProjectsLikeItsIntrinsics) {
  const Intrinsics k{64, 48, 60.0, 61.0, 31.5, 23.5};
  const ScanCamera c = ScanCamera::make_pinhole(k);
  ASSERT_TRUE(c.valid());
  const Eigen::Vector3f p(0.3f, -0.2f, 2.0f);
  float u = 0, v = 0;
  ASSERT_TRUE(c.project(p, u, v));
  const Eigen::Vector2d expected = k.project(p.cast<double>());
  EXPECT_NEAR(u, expected.x(), 1e-4);
  EXPECT_NEAR(v, expected.y(), 1e-4);
  int x = 0, y = 0;
  ASSERT_TRUE(c.pixel_of(p, x, y));
  EXPECT_EQ(x, static_cast<int>(std::lround(expected.x())));
  EXPECT_EQ(y, static_cast<int>(std::lround(expected.y())));
  EXPECT_FALSE(c.project({0.0f, 0.0f, -1.0f}, u, v));
  EXPECT_FALSE(c.pixel_of({10.0f, 0.0f, 1.0f}, x, y));  // far outside the image
  EXPECT_FLOAT_EQ(c.depth(p), 2.0f);
  EXPECT_FLOAT_EQ(point_radius(c, 3.0f), 3.0f / 60.0f);
}

/// The map coordinates of `p` in double, as pixel_of() floors them (pinhole: shifted by half a
/// pixel); false where the camera cannot see the point.
bool exact_map_coordinates(const ScanCamera& c, const Eigen::Vector3f& p, double& u, double& v) {
  const Eigen::Vector3d q = p.cast<double>();
  if (!q.allFinite()) return false;
  if (c.projection == ScanProjection::kPinhole) {
    if (!(q.z() > 0.0)) return false;
    u = c.pinhole.fx * q.x() / q.z() + c.pinhole.cx + 0.5;
    v = c.pinhole.fy * q.y() / q.z() + c.pinhole.cy + 0.5;
    return true;
  }
  if (q.norm() == 0.0) return false;
  u = (std::atan2(q.y(), q.x()) + kPi) / (2.0 * kPi) * c.width;
  v = std::atan2(std::hypot(q.x(), q.y()), q.z()) / kPi * c.height;
  return true;
}

/// ScanCamera::pixels_of() against pixel_of(), its plain version, on `points`: the same answer
/// for every point whose exact map coordinates lie farther than 1e-3 pixels from a pixel's edge;
/// those nearer (fewer than 1 %) may land in the pixel beside.
void expect_pixels_of_agrees(const ScanCamera& c, const std::vector<Eigen::Vector3f>& points) {
  const int n = static_cast<int>(points.size());
  std::vector<float> xs(n), ys(n), zs(n);
  for (int k = 0; k < n; ++k) {
    xs[k] = points[k].x();
    ys[k] = points[k].y();
    zs[k] = points[k].z();
  }
  std::vector<int> px(n, -7), py(n, -7);
  c.pixels_of(xs.data(), ys.data(), zs.data(), n, px.data(), py.data());
  auto near_edge = [](double t) { return std::abs(t - std::round(t)) < 1e-3; };
  int near = 0, seen = 0;
  for (int k = 0; k < n; ++k) {
    int x = -1, y = -1;
    const bool ok = c.pixel_of(points[k], x, y);
    double u = 0.0, v = 0.0;
    if (exact_map_coordinates(c, points[k], u, v) && (near_edge(u) || near_edge(v))) {
      ++near;
      if (ok && px[k] >= 0) {
        const int dx = std::abs(px[k] - x);
        EXPECT_LE(c.projection == ScanProjection::kPinhole ? dx : std::min(dx, c.width - dx), 1)
            << "point " << points[k].transpose();
        EXPECT_LE(std::abs(py[k] - y), 1) << "point " << points[k].transpose();
      }
      continue;
    }
    seen += ok;
    ASSERT_EQ(px[k] >= 0, ok) << "point " << points[k].transpose();
    if (!ok) continue;
    ASSERT_EQ(px[k], x) << "point " << points[k].transpose();
    ASSERT_EQ(py[k], y) << "point " << points[k].transpose();
  }
  EXPECT_LT(near, n / 100);
  EXPECT_GT(seen, n / 4);
}

TEST(ScanCamera, BatchedEquirectangularProjectionAgreesWithPixelOf) {
  // The size of the map of a 6 M-point cloud, where a float azimuth is coarsest.
  const ScanCamera c = ScanCamera::make_equirectangular(2507);
  std::mt19937 rng(5);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::uniform_real_distribution<float> range(0.05f, 40.0f);
  std::vector<Eigen::Vector3f> points;
  for (int k = 0; k < 200000; ++k) {
    const Eigen::Vector3f d(gauss(rng), gauss(rng), gauss(rng));
    points.push_back(d.normalized() * range(rng));
  }
  // The axes, the poles, both sides of the azimuth's seam (-0 included), the scanner itself,
  // points that are not finite, tiny and huge ones.
  const float inf = std::numeric_limits<float>::infinity(), nan = std::nanf("");
  const std::vector<Eigen::Vector3f> special = {{1, 0, 0},           {0, 1, 0},
                                                {0, -1, 0},          {0, 0, 1},
                                                {0, 0, -1},          {-1, 0.0f, 0},
                                                {-1, -0.0f, 0},      {-1, 1e-30f, 0.5f},
                                                {0, 0, 0},           {nan, 0, 1},
                                                {inf, 0, 0},         {1, -inf, 0},
                                                {1e-30f, 0, 1e-30f}, {3e30f, -2e30f, 1e30f},
                                                {0, 0, 1e-30f}};
  points.insert(points.end(), special.begin(), special.end());
  expect_pixels_of_agrees(c, points);

  const std::vector<Eigen::Vector3f> seam = {{-1, 0.0f, 0}, {-1, -0.0f, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<float> xs, ys, zs;
  for (const Eigen::Vector3f& p : seam) {
    xs.push_back(p.x());
    ys.push_back(p.y());
    zs.push_back(p.z());
  }
  std::vector<int> px(4), py(4);
  c.pixels_of(xs.data(), ys.data(), zs.data(), 4, px.data(), py.data());
  EXPECT_EQ(px[0], c.width - 1);   // azimuth pi: the last column
  EXPECT_EQ(px[1], 0);             // azimuth -pi: the first
  EXPECT_EQ(py[2], 0);             // the zenith: the top row
  EXPECT_EQ(py[3], c.height - 1);  // the nadir: the bottom row
}

TEST(ScanCamera, BatchedPinholeProjectionAgreesWithPixelOf) {
  const ScanCamera c = ScanCamera::make_pinhole(Intrinsics{640, 480, 525.0, 526.0, 319.5, 239.5});
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> lateral(-3.0f, 3.0f), depth(-1.0f, 6.0f);
  std::vector<Eigen::Vector3f> points;
  for (int k = 0; k < 200000; ++k) points.emplace_back(lateral(rng), lateral(rng), depth(rng));
  const float nan = std::nanf("");
  const std::vector<Eigen::Vector3f> special = {
      {0, 0, 0}, {0, 0, 1}, {1, 1, 0}, {nan, 0, 1}, {0, 0, -1}, {1e30f, 0, 1}, {0, 0, 1e-30f}};
  points.insert(points.end(), special.begin(), special.end());
  expect_pixels_of_agrees(c, points);
}

TEST(ScanCamera, TheMapOfAPointCloudIsTwoHByH) {
  // Sec. 7: 2h x h with h = sqrt(pi v / 3); the paper's 3538 x 1769 maps hold about 2.99 M points.
  const ScanCamera c = ScanCamera::equirectangular_for_points(2988000);
  EXPECT_EQ(c.height, 1769);
  EXPECT_EQ(c.width, 3538);
  EXPECT_EQ(ScanCamera::equirectangular_for_points(0).height, 1);
}

TEST(RangeMap, DepthImagePixelsBecomeTheirCameraFramePoints) {
  const Intrinsics k{8, 6, 10.0, 10.0, 3.5, 2.5};
  Image<float> depth(8, 6, 2.0f);
  depth(1, 1) = 0.0f;
  RangeMap map;
  range_map_from_depth(depth, k, map);
  EXPECT_EQ(map.count_points(), 47);
  EXPECT_FALSE(map.has_point(1, 1));
  EXPECT_TRUE(map.points(5, 4).isApprox(Eigen::Vector3f(0.3f, 0.3f, 2.0f)));
  EXPECT_THROW(range_map_from_depth(Image<float>(7, 6, 1.0f), k, map), Error);
}

TEST(RangeMap, RasterisingKeepsTheNearestPointOfEachPixel) {
  RangeMap map;
  map.camera = ScanCamera::make_equirectangular(10);
  const std::vector<Eigen::Vector3f> points = {{3.0f, 0.0f, 0.0f},
                                               {2.0f, 0.0f, 0.0f},
                                               {4.0f, 0.0f, 0.0f},  // one pixel, nearest is 2 m
                                               {0.0f, 0.0f, 0.0f},  // the scanner: skipped
                                               {NAN, 0.0f, 1.0f}};  // not finite: skipped
  const std::vector<Eigen::Vector3f> normals = {
      {1.0f, 0.0f, 0.0f}, {2.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0, 0, 1}, {0, 0, 1}};
  EXPECT_EQ(rasterize_points(points, normals, map), 2);
  EXPECT_EQ(map.count_points(), 1);
  int x = 0, y = 0;
  ASSERT_TRUE(map.camera.pixel_of(points[0], x, y));
  EXPECT_EQ(map.points(x, y), Eigen::Vector3f(2.0f, 0.0f, 0.0f));
  EXPECT_EQ(map.normals(x, y), Eigen::Vector3f(-1.0f, 0.0f, 0.0f));  // unit, facing the scanner
  EXPECT_THROW(rasterize_points(points, {{0, 0, 1}}, map), Error);
}

TEST(RangeMap, NormalsOfAFloorUnderALaserScannerPointUp) {
  // The floor z = -1.5 seen by an equirectangular scanner: every grid normal is (0, 0, 1) up to
  // float rounding, including across the azimuth seam; pixels beyond the horizon see nothing.
  RangeMap map;
  map.camera = ScanCamera::make_equirectangular(60);
  std::vector<Eigen::Vector3f> points;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      const double phi = (x + 0.5) / map.camera.width * 2.0 * kPi - kPi;
      const double theta = (y + 0.5) / map.camera.height * kPi;
      if (std::cos(theta) > -0.2) continue;  // up to 11.5 degrees below the horizon
      const double t = -1.5 / std::cos(theta);
      points.emplace_back(static_cast<float>(t * std::sin(theta) * std::cos(phi)),
                          static_cast<float>(t * std::sin(theta) * std::sin(phi)), -1.5f);
    }
  ASSERT_EQ(rasterize_points(points, {}, map), 0);
  compute_range_map_normals(map, 0.2f);
  int with_normal = 0;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      if (!map.has_point(x, y)) {
        EXPECT_EQ(map.normals(x, y), Eigen::Vector3f::Zero());
        continue;
      }
      ++with_normal;
      EXPECT_NEAR(map.normals(x, y).z(), 1.0f, 1e-4f) << x << " " << y;
    }
  EXPECT_EQ(with_normal, static_cast<int>(points.size()));
}

TEST(ScanCamera, RowStretchIsOneOverTheCosineOfTheLatitude) {
  // Row y of a 2h x h map holds the directions at polar angle (y + 0.5) pi / h: its pixels are
  // sin(theta) = cos(latitude) times as wide as its rows are high.
  const ScanCamera e = ScanCamera::make_equirectangular(4);
  EXPECT_DOUBLE_EQ(e.row_stretch(0), 1.0 / std::sin(kPi / 8.0));
  EXPECT_DOUBLE_EQ(e.row_stretch(1), 1.0 / std::sin(3.0 * kPi / 8.0));
  EXPECT_NEAR(e.row_stretch(2), e.row_stretch(1), 1e-12);
  EXPECT_NEAR(e.row_stretch(3), e.row_stretch(0), 1e-12);
  EXPECT_NEAR(ScanCamera::make_equirectangular(1001).row_stretch(500), 1.0, 1e-15);
  const ScanCamera pinhole = ScanCamera::make_pinhole(Intrinsics{64, 48, 50.0, 50.0, 31.5, 23.5});
  for (int y : {0, 10, 47}) EXPECT_EQ(pinhole.row_stretch(y), 1.0);
}

TEST(ScanCamera, OntoMapCrossesTheSeamAndThePolesOfAnEquirectangularMap) {
  // A 2h x h map with h = 4: row -1 is row 0 on the opposite azimuth, row h is row h - 1.
  int x = 1, y = -1;
  EXPECT_TRUE(onto_map(x, y, 8, 4, true));
  EXPECT_EQ(x, 5);
  EXPECT_EQ(y, 0);
  x = 6, y = 5;  // two rows past the bottom, across the seam as well
  EXPECT_TRUE(onto_map(x, y, 8, 4, true));
  EXPECT_EQ(x, 2);
  EXPECT_EQ(y, 2);
  x = -1, y = 3;
  EXPECT_TRUE(onto_map(x, y, 8, 4, true));
  EXPECT_EQ(x, 7);
  EXPECT_EQ(y, 3);
  x = 0, y = 9;  // more than a height past the pole: off the map
  EXPECT_FALSE(onto_map(x, y, 8, 4, true));
  // A pinhole map has edges.
  x = 1, y = -1;
  EXPECT_FALSE(onto_map(x, y, 8, 4, false));
  x = -1, y = 1;
  EXPECT_FALSE(onto_map(x, y, 8, 4, false));
}

TEST(ScanCamera, SphereRowOffsetsProjectADiskAcrossTheViewRay) {
  // The reference in double precision: the direction through pixel (x, y)'s centre (pixel_ray())
  // plus tangent * (ox east + oy south), its azimuth and polar angle by std::atan2 as map
  // coordinates, less the centre's (u taken across the seam the short way). The offsets'
  // arctangents are polynomials of a few float ulp: within 5e-4 pixels of it on an 800 x 400 map
  // (measured 8.1e-5), at every latitude (the rows next to the poles included, where the disk
  // reaches across them) and for tangents of 0.005 (r_s = 0.1 m at 20 m) to 1.
  const ScanCamera camera = ScanCamera::make_equirectangular(400);
  const int w = camera.width, h = camera.height;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::vector<Eigen::Vector2f> o;
  while (o.size() < 64) {
    const Eigen::Vector2f d(unit(rng), unit(rng));
    if (d.squaredNorm() <= 1.0f) o.push_back(d);
  }
  double worst = 0.0;
  int crossings = 0;
  for (int y : {0, 1, 3, 40, 133, 199, 200, 311, 396, 399}) {
    const ScanCamera::SphereRow row = camera.sphere_row(y);
    for (float tangent : {0.005f, 0.05f, 0.3f, 1.0f}) {
      std::vector<float> du(o.size()), dv(o.size());
      row.offsets(tangent, o.data(), static_cast<int>(o.size()), du.data(), dv.data());
      for (int x : {0, 123, 799}) {
        const Eigen::Vector3d ray = camera.pixel_ray(x, y);
        const Eigen::Vector3d east = Eigen::Vector3d::UnitZ().cross(ray).normalized();
        const Eigen::Vector3d south = east.cross(ray);
        for (std::size_t k = 0; k < o.size(); ++k) {
          const Eigen::Vector3d d = ray + tangent * (o[k].x() * east + o[k].y() * south);
          const double u = (std::atan2(d.y(), d.x()) + kPi) / (2.0 * kPi) * w;
          const double v = std::atan2(std::hypot(d.x(), d.y()), d.z()) / kPi * h;
          double ref_du = u - (x + 0.5);
          if (ref_du > 0.5 * w) ref_du -= w;
          if (ref_du < -0.5 * w) ref_du += w;
          const double ref_dv = v - (y + 0.5);
          double err_u = std::abs(du[k] - ref_du);
          err_u = std::min(err_u, std::abs(err_u - w));  // +-w/2 are the same column
          worst = std::max({worst, err_u, std::abs(dv[k] - ref_dv)});
          crossings += std::abs(ref_du) > 0.25 * w ? 1 : 0;
        }
      }
    }
  }
  std::printf("worst offset error %.2e px; %d offsets reach across a pole\n", worst, crossings);
  EXPECT_LT(worst, 5e-4);
  EXPECT_GT(crossings, 100);
  // At the equator, a small disk is the chart's: tangent * pixels per radian both ways.
  const ScanCamera::SphereRow equator = camera.sphere_row(200);
  const Eigen::Vector2f east_south(0.6f, -0.8f);
  float du = 0.0f, dv = 0.0f;
  equator.offsets(1e-3f, &east_south, 1, &du, &dv);
  EXPECT_NEAR(du, 0.6 * 1e-3 * w / (2.0 * kPi), 1e-4);
  EXPECT_NEAR(dv, -0.8 * 1e-3 * h / kPi, 1e-4);
}

TEST(RangeMap, NormalsNearAnEquirectangularPoleSpanTheirSupportAlongTheRing) {
  // The floor 0.5 m below a laser scanner, 2 mm of range noise, an 800 x 400 map. Near the nadir
  // a row's pixels are a few tenths of a millimetre wide: a window of as many pixels both ways
  // (2 cm high) is a strip a few millimetres wide, its points nearly on a line whose plane the
  // noise decides. Widened along the row to 2 cm, the fits find the floor. Measured within 25
  // degrees of the nadir, normals within 10 degrees of up: 58.9 % with square windows, 100 %.
  RangeMap map;
  map.camera = ScanCamera::make_equirectangular(400);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<Eigen::Vector3f> points;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      const Eigen::Vector3d ray = map.camera.pixel_ray(x, y);
      if (ray.z() > -0.3) continue;
      const double t = -0.5 / ray.z() + noise(rng);
      points.push_back((t * ray).cast<float>());
    }
  ASSERT_EQ(rasterize_points(points, {}, map), 0);
  compute_scan_normals(map);
  long long near_pole = 0, up = 0;
  const double min_theta = kPi - 25.0 * kPi / 180.0;
  for (int y = 0; y < map.camera.height; ++y) {
    if ((y + 0.5) * kPi / map.camera.height < min_theta) continue;
    for (int x = 0; x < map.camera.width; ++x) {
      if (!map.has_point(x, y)) continue;
      ++near_pole;
      up += map.normals(x, y).z() > std::cos(10.0 * kPi / 180.0) ? 1 : 0;
    }
  }
  const double share = static_cast<double>(up) / static_cast<double>(near_pole);
  std::printf(
      "within 25 degrees of the nadir: %lld points, normals within 10 degrees of up: %.1f %%\n",
      near_pole, 100.0 * share);
  EXPECT_GT(near_pole, 20000);
  EXPECT_GT(share, 0.99);
}

TEST(RangeMap, NoNormalAcrossADepthJump) {
  const Intrinsics k{10, 4, 10.0, 10.0, 4.5, 1.5};
  Image<float> depth(10, 4, 1.0f);
  for (int y = 0; y < 4; ++y)
    for (int x = 5; x < 10; ++x) depth(x, y) = 2.0f;
  RangeMap map;
  range_map_from_depth(depth, k, map);
  compute_range_map_normals(map, 0.05f);
  // Pixels 4 and 5 take their normals from their own side of the jump: both get the plane's
  // normal; a lone column between two jumps (points on a line) gets none.
  EXPECT_NEAR(map.normals(4, 1).z(), -1.0f, 1e-6f);
  EXPECT_NEAR(map.normals(5, 1).z(), -1.0f, 1e-6f);
  for (int y = 0; y < 4; ++y) depth(7, y) = 3.0f;
  range_map_from_depth(depth, k, map);
  compute_range_map_normals(map, 0.05f);
  EXPECT_EQ(map.normals(7, 1), Eigen::Vector3f::Zero());
}

/// A tilted plane seen by a 640 x 480 depth camera at about 2.5 m, depth noise of sigma
/// `noise_m` (seeded), and its exact normal (facing the camera).
RangeMap noisy_plane(float noise_m, Eigen::Vector3f& normal) {
  normal = Eigen::Vector3f(0.3f, -0.2f, -1.0f).normalized();
  return noisy_plane_scan(
      normal, 2.5f, [noise_m](float) { return noise_m; }, 7);
}

/// Mean angle (degrees) between the map's normals and `normal` over the pixels 20 px or more
/// inside the image; `missing` counts those without a normal.
double mean_angle_deg(const RangeMap& map, const Eigen::Vector3f& normal, int& missing) {
  double sum = 0.0;
  int n = 0;
  missing = 0;
  for (int y = 20; y < map.camera.height - 20; ++y)
    for (int x = 20; x < map.camera.width - 20; ++x) {
      const Eigen::Vector3f& m = map.normals(x, y);
      if (m.squaredNorm() < 0.5f) {
        ++missing;
        continue;
      }
      sum += std::acos(std::clamp(static_cast<double>(m.dot(normal)), -1.0, 1.0)) * 180.0 / kPi;
      ++n;
    }
  return n > 0 ? sum / n : 180.0;
}

TEST(RangeMap, AMetricSupportAveragesTheDepthNoiseAwayAndKeepsAnExactPlaneExact) {
  Eigen::Vector3f normal;
  // Exact depth: every window gives the plane's normal, the wide ones (2 cm is 4.7 px at 2.5 m:
  // radius 5, read at 7 x 7 pixels spread over it) too.
  RangeMap exact = noisy_plane(0.0f, normal);
  compute_range_map_normals(exact, 0.05f, 2, 0.02f, 16);
  int missing = 0;
  EXPECT_LT(mean_angle_deg(exact, normal, missing), 0.05);
  EXPECT_EQ(missing, 0);
  // 5 mm of noise at 2.5 m (a Kinect's order): 5 x 5 pixels (2 cm across) leave the normals
  // about 22 degrees off on average; the 2 cm radius about 4 (measured), every pixel still with
  // a normal. compute_scan_normals() is that 2 cm and 16 points.
  RangeMap narrow = noisy_plane(0.005f, normal);
  RangeMap wide = narrow;
  compute_range_map_normals(narrow, 0.05f, 2);
  compute_scan_normals(wide);
  int narrow_missing = 0, wide_missing = 0;
  const double narrow_deg = mean_angle_deg(narrow, normal, narrow_missing);
  const double wide_deg = mean_angle_deg(wide, normal, wide_missing);
  EXPECT_GT(narrow_deg, 15.0);
  EXPECT_LT(wide_deg, narrow_deg / 4.0) << narrow_deg;
  EXPECT_EQ(wide_missing, 0);
}

TEST(RangeMap, ASparseMapGrowsTheWindowUntilItHoldsTheLeastNumberOfPoints) {
  // The plane z = 2 with a point on every third pixel in both directions (a cloud rebuilt into a
  // finer map): a 5 x 5 window around a point holds that point alone, so no normal; with 16
  // points asked for, the window grows to 13 x 13 (25 points) and the normal is exact.
  const Intrinsics k{60, 60, 60.0, 60.0, 29.5, 29.5};
  Image<float> depth(k.width, k.height, 0.0f);
  for (int y = 0; y < k.height; y += 3)
    for (int x = 0; x < k.width; x += 3) depth(x, y) = 2.0f;
  RangeMap map;
  range_map_from_depth(depth, k, map);
  RangeMap grown = map;
  compute_range_map_normals(map, 0.05f, 2);
  compute_range_map_normals(grown, 0.05f, 2, 0.0f, 16);
  EXPECT_EQ(map.normals(30, 30), Eigen::Vector3f::Zero());
  EXPECT_NEAR(grown.normals(30, 30).z(), -1.0f, 1e-6f);
  // A window never grows past kMaxNormalRadiusPx: points 9 px apart stay without normals.
  Image<float> sparse(k.width, k.height, 0.0f);
  for (int y = 0; y < k.height; y += 9)
    for (int x = 0; x < k.width; x += 9) sparse(x, y) = 2.0f;
  range_map_from_depth(sparse, k, grown);
  compute_range_map_normals(grown, 0.05f, 2, 0.0f, 16);
  EXPECT_EQ(grown.normals(27, 27), Eigen::Vector3f::Zero());
}

/// A plane seen by a 640 x 480 depth camera from about 1.2 m (top rows) to 3.3 m (bottom rows),
/// depth noise of sigma `near_m` where the true depth is below 1.8 m and `far_m` beyond (seeded),
/// its normal (facing the camera) and the plane's offset d (n . p = -d).
RangeMap noisy_slope(float near_m, float far_m, Eigen::Vector3f& normal, float& offset) {
  normal = Eigen::Vector3f(0.1f, 1.1f, -1.0f).normalized();
  offset = 1.2f;
  return noisy_plane_scan(
      normal, offset, [near_m, far_m](float z) { return z < 1.8f ? near_m : far_m; }, 11);
}

/// Mean angle (degrees) between the map's normals and `normal`, and RMS distance (m) of the
/// points (moved by `offset_m` along their normals when it is not empty) to the plane
/// n . p = -d, over the pixels 20 px or more inside the image whose depth lies in [lo, hi).
struct PlaneErrors {
  double angle_deg = 0.0;
  double rms_m = 0.0;
  long long pixels = 0;
};
PlaneErrors plane_errors(const RangeMap& map, const Image<float>& offset_m,
                         const Eigen::Vector3f& normal, float d, float lo, float hi) {
  PlaneErrors e;
  double angle = 0.0, squares = 0.0;
  for (int y = 20; y < map.camera.height - 20; ++y)
    for (int x = 20; x < map.camera.width - 20; ++x) {
      const Eigen::Vector3f& p = map.points(x, y);
      if (!(p.z() >= lo && p.z() < hi)) continue;
      const Eigen::Vector3f& m = map.normals(x, y);
      const Eigen::Vector3f q = offset_m.empty() ? p : Eigen::Vector3f(p + offset_m(x, y) * m);
      angle += std::acos(std::clamp(static_cast<double>(m.dot(normal)), -1.0, 1.0)) * 180.0 / kPi;
      squares += std::pow(static_cast<double>(normal.dot(q) + d), 2);
      ++e.pixels;
    }
  if (e.pixels > 0) {
    e.angle_deg = angle / static_cast<double>(e.pixels);
    e.rms_m = std::sqrt(squares / static_cast<double>(e.pixels));
  }
  return e;
}

/// `map` with the normals of compute_scan_normals()'s first fits alone (2 cm, 16 points).
RangeMap first_fits(const RangeMap& map) {
  RangeMap first = map;
  compute_range_map_normals(first, kScanNormalMaxJumpRatio, 2, kScanNormalSupportM,
                            kScanNormalMinPoints);
  return first;
}

TEST(RangeMap, AScansOwnNoiseWidensItsPlaneFitsWhereTheNoiseIsLarge) {
  // Half a millimetre of noise nearer than 1.8 m (a laser's order: 8 sigma stay under the 2 cm
  // floor), 8 mm beyond (a Kinect's at 3 m). compute_scan_normals() measures that noise from its
  // first fits' residuals and fits the far pixels again over 8 sigma (windows up to 25 x 25
  // there); the near ones keep their first fit bit for bit and no offset. Measured (far:
  // 2.0-3.2 m): mean normal error 2.80 -> 1.79 degrees (1.96 with windows of at most 17 x 17), the
  // points moved onto their planes 4.00 -> 0.59 mm RMS from the true plane (the depth noise is
  // along the rays, at up to 70 degrees from the normal).
  Eigen::Vector3f normal;
  float d = 0.0f;
  RangeMap map = noisy_slope(0.0005f, 0.008f, normal, d);
  const RangeMap first = first_fits(map);
  const Image<float> offset = compute_scan_normals(map);
  ASSERT_FALSE(offset.empty());
  const PlaneErrors before = plane_errors(first, {}, normal, d, 2.0f, 3.2f);
  const PlaneErrors after = plane_errors(map, offset, normal, d, 2.0f, 3.2f);
  std::printf("far: %lld pixels, normal error %.2f -> %.2f deg, RMS %.2f -> %.2f mm\n",
              after.pixels, before.angle_deg, after.angle_deg, before.rms_m * 1e3,
              after.rms_m * 1e3);
  // The noise kept with the map (the spread along the normal: 0.47 mm at 1.2 m and 3.05 mm at 3 m
  // measured, the depth noise times the cosine of the 60-70 degrees between ray and normal).
  std::printf("measured noise: %.2f mm at 1.2 m, %.2f mm at 3 m\n", map.noise.sigma(1.2f) * 1e3,
              map.noise.sigma(3.0f) * 1e3);
  EXPECT_GT(map.noise.sigma(1.2f), 0.0003f);
  EXPECT_LT(map.noise.sigma(1.2f), 0.0006f);
  EXPECT_GT(map.noise.sigma(3.0f), 0.0025f);
  EXPECT_LT(map.noise.sigma(3.0f), 0.0040f);
  ASSERT_GT(after.pixels, 50000);
  EXPECT_LT(after.angle_deg, before.angle_deg * 0.8);
  EXPECT_LT(after.rms_m, before.rms_m / 3.0);
  long long near = 0;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      if (!(map.points(x, y).z() < 1.6f)) continue;
      ++near;
      EXPECT_EQ(offset(x, y), 0.0f);
      EXPECT_EQ(map.normals(x, y), first.normals(x, y));
    }
  EXPECT_GT(near, 20000);
}

TEST(RangeMap, AScanWithoutLargeNoiseKeepsItsFirstFitAndGivenNormals) {
  // One millimetre everywhere (a laser scanner): no support grows, no offsets, the normals are
  // the 2 cm fits.
  Eigen::Vector3f normal;
  float d = 0.0f;
  RangeMap map = noisy_slope(0.001f, 0.001f, normal, d);
  const RangeMap first = first_fits(map);
  EXPECT_TRUE(compute_scan_normals(map).empty());
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) ASSERT_EQ(map.normals(x, y), first.normals(x, y));
  // Nor does a small far patch of spread points (30 x 30 pixels of a wall at 6 m with 8 mm of
  // noise, the farthest depth bins their own): under 1/256 of the fits, it is not the scan's
  // noise (a room's farthest points are its corners, where a fit's spread is the crease).
  RangeMap patch = noisy_slope(0.001f, 0.001f, normal, d);
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.0f, 0.008f);
  const Intrinsics k{640, 480, 585.0, 585.0, 319.5, 239.5};
  for (int y = 200; y < 230; ++y)
    for (int x = 300; x < 330; ++x) {
      const float z = 6.0f + noise(rng);
      patch.points(x, y) = k.unproject(static_cast<float>(x), static_cast<float>(y), z);
    }
  EXPECT_TRUE(compute_scan_normals(patch).empty());
  // Normals that came with the scan (a cloud's own) are neither measured nor fitted again, however
  // noisy the points.
  RangeMap given = noisy_slope(0.008f, 0.008f, normal, d);
  for (int y = 0; y < given.camera.height; ++y)
    for (int x = 0; x < given.camera.width; ++x) given.normals(x, y) = normal;
  EXPECT_TRUE(compute_scan_normals(given).empty());
  EXPECT_FALSE(given.noise.known());
  for (int y = 0; y < given.camera.height; ++y)
    for (int x = 0; x < given.camera.width; ++x) ASSERT_EQ(given.normals(x, y), normal);
}

TEST(RangeMap, APointWhoseWiderFitFailsKeepsItsFirstNormal) {
  // A 3 x 3-pixel patch of a wall at 4 m in front of a wall at 6 m, both with 8 mm of noise. The
  // 2 cm fit there reads the 7 x 7 pixels around the patch's middle and finds the patch's nine
  // points; the noise widens the support to a window several times wider, read at 7 x 7 pixels
  // spread over it, of which only the middle lies on the near wall: too few points for a plane.
  // The middle keeps the first fit's normal (and no offset) instead of losing its normal.
  RangeMap map = noisy_plane_scan(
      Eigen::Vector3f(0.05f, 0.02f, -1.0f).normalized(), 4.0f, [](float) { return 0.008f; }, 13);
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x)
      if (x < 300 || x > 302 || y < 239 || y > 241) map.points(x, y) *= 1.5f;
  const RangeMap first = first_fits(map);
  const Image<float> offset = compute_scan_normals(map);
  ASSERT_FALSE(offset.empty());
  ASSERT_GT(first.normals(301, 240).squaredNorm(), 0.5f);
  EXPECT_EQ(map.normals(301, 240), first.normals(301, 240));
  EXPECT_EQ(offset(301, 240), 0.0f);
  EXPECT_NE(offset(100, 100), 0.0f);  // the far wall's pixels are fitted again
}

TEST(RangeMap, AWiderFitKeepsBothFacesOfACrease) {
  // The inside corner of a floor 0.6 m below the camera and a wall 2 m ahead, with 3 mm of depth
  // noise (a depth camera's after its filter). The noise widens the fits to 8 sigma, 2.4 cm; a
  // window centred on a point near the crease holds both faces, and a plane across them moves
  // the point off its face and tilts its normal. The windows beside the point hold one face.
  // Over the points whose true surface point lies within 5 cm of the crease, measured: the moved
  // points 3.1 -> 1.8 mm RMS from their face, normals 19.9 -> 13.1 degrees off on average.
  constexpr float kFloorY = 0.6f, kWallZ = 2.0f, kNear = 0.05f;
  const auto depth_of_ray = [&](const Eigen::Vector3f& ray) {
    return ray.y() > 0.0f ? std::min(kFloorY / ray.y(), kWallZ) : kWallZ;
  };
  RangeMap map = noisy_depth_scan(
      depth_of_ray, [](float) { return 0.003f; }, 17);
  const Image<float> offset = compute_scan_normals(map);
  ASSERT_FALSE(offset.empty());
  const Intrinsics& k = map.camera.pinhole;
  double squares = 0.0, angles = 0.0;
  long long pixels = 0;
  for (int y = 20; y < map.camera.height - 20; ++y)
    for (int x = 20; x < map.camera.width - 20; ++x) {
      const Eigen::Vector3f ray(static_cast<float>((x - k.cx) / k.fx),
                                static_cast<float>((y - k.cy) / k.fy), 1.0f);
      const Eigen::Vector3f truth = ray * depth_of_ray(ray);
      const bool floor = truth.z() < kWallZ;
      if (!((floor ? kWallZ - truth.z() : kFloorY - truth.y()) <= kNear)) continue;
      const Eigen::Vector3f face = floor ? Eigen::Vector3f(0, -1, 0) : Eigen::Vector3f(0, 0, -1);
      const Eigen::Vector3f& n = map.normals(x, y);
      ASSERT_GT(n.squaredNorm(), 0.5f) << x << ", " << y;
      const Eigen::Vector3f q = map.points(x, y) + offset(x, y) * n;
      const float distance = floor ? q.y() - kFloorY : q.z() - kWallZ;
      squares += static_cast<double>(distance) * distance;
      angles += std::acos(std::clamp(static_cast<double>(n.dot(face)), -1.0, 1.0)) * 180.0 / kPi;
      ++pixels;
    }
  ASSERT_GT(pixels, 10000);
  const double rms_mm = std::sqrt(squares / static_cast<double>(pixels)) * 1e3;
  const double angle_deg = angles / static_cast<double>(pixels);
  std::printf("near the crease: %lld pixels, %.1f mm RMS from their face, normals %.1f deg off\n",
              pixels, rms_mm, angle_deg);
  EXPECT_LT(rms_mm, 2.5);
  EXPECT_LT(angle_deg, 16.0);
}

}  // namespace
}  // namespace aoscan
