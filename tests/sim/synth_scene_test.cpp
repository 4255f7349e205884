/// @file synth_scene_test.cpp
/// @brief Tests for src/capture/synth_scene.h: exact ray hits, distances and meshes of analytic
/// scenes.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>

#include "core/status.h"
#include "sim/synth_scene.h"

namespace aoscan {
namespace {

constexpr double kPi = 3.14159265358979323846;

Ray make_ray(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  return {origin, direction.normalized()};
}

void expect_vector_near(const Eigen::Vector3d& actual, const Eigen::Vector3d& expected,
                        double tolerance) {
  EXPECT_LT((actual - expected).norm(), tolerance)
      << "actual " << actual.transpose() << ", expected " << expected.transpose();
}

TEST(AnalyticScene, BoxHitsEntryAndExitFaces) {
  AnalyticScene scene("box");
  scene.add_box({1, -1, -1}, {2, 1, 1});
  Hit hit;
  // Straight along +x: enters the x = 1 face.
  ASSERT_TRUE(scene.intersect(make_ray({0, 0, 0}, {1, 0, 0}), 0.0, 10.0, &hit));
  EXPECT_DOUBLE_EQ(hit.t, 1.0);
  expect_vector_near(hit.normal, {-1, 0, 0}, 1e-15);
  // Direction (3, 4, 0) / 5 from (0, -1.5, 0): the y = -1 plane is crossed at t = 0.625 outside the
  // x slab; the box is entered through x = 1 at t = 5/3 and left through y = 1 at t = 3.125.
  const Ray oblique = make_ray({0, -1.5, 0}, {3, 4, 0});
  ASSERT_TRUE(scene.intersect(oblique, 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.t, 5.0 / 3.0, 1e-12);
  expect_vector_near(hit.normal, {-1, 0, 0}, 1e-15);
  // From inside the box (t_min past the entry) the exit face is hit, outward normal +y.
  ASSERT_TRUE(scene.intersect(oblique, 2.0, 10.0, &hit));
  EXPECT_NEAR(hit.t, 3.125, 1e-12);
  expect_vector_near(hit.normal, {0, 1, 0}, 1e-15);
  // Interval limits are inclusive and respected.
  EXPECT_FALSE(scene.intersect(make_ray({0, 0, 0}, {1, 0, 0}), 0.0, 0.99, &hit));
  EXPECT_TRUE(scene.intersect(make_ray({0, 0, 0}, {1, 0, 0}), 0.0, 1.0, &hit));
  EXPECT_FALSE(scene.intersect(oblique, 3.2, 10.0, &hit));
  // Misses: pointing away, passing beside, parallel to a face outside its slab.
  EXPECT_FALSE(scene.intersect(make_ray({0, 0, 0}, {-1, 0, 0}), 0.0, 10.0, &hit));
  EXPECT_FALSE(scene.intersect(make_ray({0, 0, 0}, {0, 1, 0}), 0.0, 10.0, &hit));
  EXPECT_FALSE(scene.intersect(make_ray({0, 1.5, 0}, {1, 0, 0}), 0.0, 10.0, &hit));
  // A second box in front wins; a null hit pointer is allowed.
  scene.add_box({0.5, -0.1, -0.1}, {0.6, 0.1, 0.1});
  ASSERT_TRUE(scene.intersect(make_ray({0, 0, 0}, {1, 0, 0}), 0.0, 10.0, &hit));
  EXPECT_DOUBLE_EQ(hit.t, 0.5);
  EXPECT_TRUE(scene.intersect(make_ray({0, 0, 0}, {1, 0, 0}), 0.0, 10.0, nullptr));
}

TEST(AnalyticScene, SphereHitsWithHandComputedNormals) {
  AnalyticScene scene("sphere");
  scene.add_sphere({0, 0, 5}, 1.0);
  Hit hit;
  ASSERT_TRUE(scene.intersect(make_ray({0, 0, 0}, {0, 0, 1}), 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.t, 4.0, 1e-12);
  expect_vector_near(hit.normal, {0, 0, -1}, 1e-12);
  // Offset 0.6 from the axis: z = 5 - sqrt(1 - 0.36) = 4.2.
  ASSERT_TRUE(scene.intersect(make_ray({0.6, 0, 0}, {0, 0, 1}), 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.t, 4.2, 1e-12);
  expect_vector_near(hit.normal, {0.6, 0, -0.8}, 1e-12);
  // Past the entry the far side is hit from inside, outward normal.
  ASSERT_TRUE(scene.intersect(make_ray({0.6, 0, 0}, {0, 0, 1}), 4.5, 10.0, &hit));
  EXPECT_NEAR(hit.t, 5.8, 1e-12);
  expect_vector_near(hit.normal, {0.6, 0, 0.8}, 1e-12);
  EXPECT_FALSE(scene.intersect(make_ray({1.01, 0, 0}, {0, 0, 1}), 0.0, 10.0, &hit));
  EXPECT_FALSE(scene.intersect(make_ray({0, 0, 0}, {0, 0, -1}), 0.0, 10.0, &hit));
  EXPECT_FALSE(scene.intersect(make_ray({0, 0, 0}, {0, 0, 1}), 0.0, 3.9, &hit));
  EXPECT_FALSE(scene.intersect(make_ray({0.6, 0, 0}, {0, 0, 1}), 5.9, 10.0, &hit));
}

TEST(AnalyticScene, SphereInFrontOfBoxAndBoxInFrontOfSphere) {
  AnalyticScene scene("mixed");
  scene.add_box({-1, -1, 3}, {1, 1, 3.5});
  scene.add_sphere({0, 0, 2}, 0.5);
  Hit hit;
  ASSERT_TRUE(scene.intersect(make_ray({0, 0, 0}, {0, 0, 1}), 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.t, 1.5, 1e-12);
  // Beside the sphere the box is hit.
  ASSERT_TRUE(scene.intersect(make_ray({0.7, 0, 0}, {0, 0, 1}), 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.t, 3.0, 1e-12);
  expect_vector_near(hit.normal, {0, 0, -1}, 1e-15);
  // Looking back from behind the box: the box's z = 3.5 face first.
  ASSERT_TRUE(scene.intersect(make_ray({0, 0, 5}, {0, 0, -1}), 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.t, 1.5, 1e-12);
  expect_vector_near(hit.normal, {0, 0, 1}, 1e-15);
}

TEST(AnalyticScene, OccludedAgreesWithIntersectOnRandomRays) {
  const AnalyticScene scene = AnalyticScene::make("corner");
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> coord(-0.5, 3.0);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> range(0.0, 4.0);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    Eigen::Vector3d d(unit(gen), unit(gen), unit(gen));
    if (d.norm() < 1e-3) continue;
    const Ray ray = make_ray({coord(gen), coord(gen), coord(gen)}, d);
    const double t0 = range(gen);
    const double t1 = t0 + range(gen);
    const bool any = scene.occluded(ray, t0, t1);
    Hit hit;
    const bool nearest = scene.intersect(ray, t0, t1, &hit);
    ASSERT_EQ(any, nearest) << "ray " << i;
    if (nearest) {
      ++hits;
      EXPECT_GE(hit.t, t0);
      EXPECT_LE(hit.t, t1);
      EXPECT_NEAR(hit.normal.norm(), 1.0, 1e-12);
      EXPECT_LT(scene.distance(ray.origin + hit.t * ray.direction), 1e-9);
    }
  }
  EXPECT_GT(hits, 2000);
}

TEST(AnalyticScene, DistancesToBoxFaceEdgeCornerAndSphere) {
  AnalyticScene scene("unit");
  scene.add_box({0, 0, 0}, {1, 1, 1});
  EXPECT_NEAR(scene.distance({0.5, 0.5, 1.3}), 0.3, 1e-12);  // face
  EXPECT_NEAR(scene.distance({1.3, 0.5, 1.4}), 0.5, 1e-12);  // edge 3-4-5
  EXPECT_NEAR(scene.distance({1.3, 1.4, -1.2}), std::sqrt(0.09 + 0.16 + 1.44), 1e-12);  // corner
  EXPECT_NEAR(scene.distance({0.5, 0.5, 0.9}), 0.1, 1e-12);  // inside, nearest face z = 1
  EXPECT_NEAR(scene.signed_distance({0.5, 0.5, 0.9}), -0.1, 1e-12);
  EXPECT_NEAR(scene.signed_distance({1.3, 0.5, 1.4}), 0.5, 1e-12);
  EXPECT_EQ(scene.distance({1, 0.2, 0.7}), 0.0);

  scene.add_sphere({3, 0, 0}, 0.5);
  EXPECT_NEAR(scene.distance({3, 0, 2}), 1.5, 1e-12);
  EXPECT_NEAR(scene.distance({3, 0.1, 0}), 0.4, 1e-12);
  EXPECT_NEAR(scene.signed_distance({3, 0.1, 0}), -0.4, 1e-12);
  // Between the two: nearer to the sphere (2.5 - 2.2 = 0.3) than to the box (1.2).
  EXPECT_NEAR(scene.distance({2.2, 0, 0}), 0.3, 1e-12);
}

TEST(AnalyticScene, NearestSurfacePointOfFacesEdgesAndSphere) {
  AnalyticScene scene("unit");
  scene.add_box({0, 0, 0}, {1, 1, 1});
  scene.add_sphere({3, 0, 0}, 0.5);
  const auto expect_point = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& point,
                                const Eigen::Vector3d& normal) {
    const std::optional<SurfacePoint> s = scene.nearest_surface_point(p, 1.0);
    ASSERT_TRUE(s) << p.transpose();
    expect_vector_near(s->p, point, 1e-12);
    expect_vector_near(s->normal, normal, 1e-12);
  };
  expect_point({0.5, 0.5, 1.3}, {0.5, 0.5, 1.0}, {0, 0, 1});  // above a face
  expect_point({0.5, 0.5, 0.9}, {0.5, 0.5, 1.0}, {0, 0, 1});  // inside, below the same face
  // Inside, nearer to the x = 1 face than to the y = 1 face by 0.1 mm: the signed distance's
  // finite-difference gradient blends the two normals here.
  expect_point({0.9973, 0.9972, 0.5}, {1.0, 0.9972, 0.5}, {1, 0, 0});
  // Beyond an edge: the edge point, with the normal of the first face listed there (+x).
  expect_point({1.3, 0.5, 1.4}, {1.0, 0.5, 1.0}, {1, 0, 0});
  expect_point({3.0, 0.0, 1.0}, {3.0, 0.0, 0.5}, {0, 0, 1});  // sphere, from outside
  expect_point({3.0, 0.1, 0.0}, {3.0, 0.5, 0.0}, {0, 1, 0});  // and from inside
  EXPECT_FALSE(scene.nearest_surface_point({0.5, 0.5, 1.3}, 0.29));
  EXPECT_FALSE(scene.nearest_surface_point({0.5, 0.5, std::nan("")}, 1.0));
}

TEST(AnalyticScene, NearestSurfacePointSkipsFacesHiddenAgainstAnotherSolid) {
  // The corner scene's cabinet stands against the wall x = 0: their touching faces are not surface.
  const AnalyticScene scene = AnalyticScene::make("corner");
  const auto nearest = [&](const Eigen::Vector3d& p) {
    const std::optional<SurfacePoint> s = scene.nearest_surface_point(p, 0.02);
    EXPECT_TRUE(s) << p.transpose();
    return s.value_or(SurfacePoint{});
  };
  // Inside the cabinet, 1 mm from its back (against the wall) and 4 mm from its side y = 1.6.
  SurfacePoint s = nearest({0.001, 1.604, 0.3});
  expect_vector_near(s.p, {0.001, 1.6, 0.3}, 1e-12);
  expect_vector_near(s.normal, {0, -1, 0}, 1e-12);
  // Inside the wall behind the cabinet: the line where the cabinet's side meets the wall.
  s = nearest({-0.002, 1.604, 0.3});
  expect_vector_near(s.p, {0.0, 1.6, 0.3}, 1e-12);
  expect_vector_near(s.normal, {0, -1, 0}, 1e-12);
  // In front of the wall beside the cabinet: the wall.
  s = nearest({0.003, 1.59, 0.3});
  expect_vector_near(s.p, {0.0, 1.59, 0.3}, 1e-12);
  expect_vector_near(s.normal, {1, 0, 0}, 1e-12);
}

TEST(AnalyticScene, RejectsDegeneratePrimitives) {
  AnalyticScene scene("bad");
  EXPECT_THROW(scene.add_box({0, 0, 0}, {1, 0, 1}), Error);
  EXPECT_THROW(scene.add_box({0, 0, 0}, {1, std::nan(""), 1}), Error);
  EXPECT_THROW(scene.add_sphere({0, 0, 0}, 0.0), Error);
  EXPECT_THROW(scene.add_sphere({0, 0, 0}, -1.0), Error);
  EXPECT_TRUE(scene.boxes().empty());
  EXPECT_TRUE(scene.spheres().empty());
}

double mesh_area(const TriangleMesh& mesh) {
  double area = 0.0;
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[f[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[f[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

TEST(AnalyticScene, MeshLiesOnTheSurfaceWithOutwardNormals) {
  for (const std::string& name : AnalyticScene::names()) {
    SCOPED_TRACE(name);
    const AnalyticScene scene = AnalyticScene::make(name);
    const TriangleMesh mesh = scene.to_mesh();
    ASSERT_FALSE(mesh.empty());
    ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
    EXPECT_TRUE(mesh.quality.empty());
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
      ASSERT_LT(scene.distance(mesh.vertices[i].cast<double>()), 2e-4) << "vertex " << i;
      ASSERT_NEAR(mesh.normals[i].norm(), 1.0f, 1e-5f);
    }
    for (std::size_t i = 0; i < mesh.faces.size(); ++i) {
      const Eigen::Vector3i& f = mesh.faces[i];
      ASSERT_TRUE((f.array() >= 0).all() &&
                  (f.array() < static_cast<int>(mesh.vertices.size())).all());
      const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
      const Eigen::Vector3d b = mesh.vertices[f[1]].cast<double>();
      const Eigen::Vector3d c = mesh.vertices[f[2]].cast<double>();
      // Flat triangles stay within the tessellation tolerance of the surface.
      ASSERT_LT(scene.distance((a + b + c) / 3.0), 1e-4 + 1e-6) << "face " << i;
      // Counter-clockwise seen from outside: the geometric normal agrees with the vertex normals.
      const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
      for (int k = 0; k < 3; ++k) ASSERT_GT(n.dot(mesh.normals[f[k]].cast<double>()), 0.99);
    }
  }
}

TEST(AnalyticScene, BoxMeshIsExactAndSphereMeshIsFine) {
  AnalyticScene box_scene("box");
  box_scene.add_box({0, 0, 0}, {1, 2, 3});
  const TriangleMesh box = box_scene.to_mesh();
  EXPECT_EQ(box.faces.size(), 12u);
  EXPECT_EQ(box.vertices.size(), 24u);
  EXPECT_NEAR(mesh_area(box), 2.0 * (2 + 3 + 6), 1e-5);

  for (const double r : {0.05, 0.2, 1.0}) {
    SCOPED_TRACE(r);
    AnalyticScene scene("sphere");
    scene.add_sphere({1, -2, 0.5}, r);
    const TriangleMesh mesh = scene.to_mesh();
    const double area = mesh_area(mesh);
    const double exact = 4.0 * kPi * r * r;
    EXPECT_LT(area, exact);
    EXPECT_GT(area, exact * (1.0 - 0.005));
    // The largest deviation (face centres of the tessellation) stays under 0.2 mm.
    double worst = 0.0;
    for (const auto& f : mesh.faces) {
      const Eigen::Vector3d c =
          (mesh.vertices[f[0]].cast<double>() + mesh.vertices[f[1]].cast<double>() +
           mesh.vertices[f[2]].cast<double>()) /
          3.0;
      worst = std::max(worst, scene.distance(c));
    }
    EXPECT_LT(worst, 2e-4);
  }
}

TEST(AnalyticScene, BuiltInScenesTouchButNeverOverlap) {
  for (const std::string& name : AnalyticScene::names()) {
    SCOPED_TRACE(name);
    const AnalyticScene scene = AnalyticScene::make(name);
    EXPECT_EQ(scene.name(), name);
    const auto& boxes = scene.boxes();
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      for (std::size_t j = i + 1; j < boxes.size(); ++j) {
        const Eigen::Vector3d lo = boxes[i].min.cwiseMax(boxes[j].min);
        const Eigen::Vector3d hi = boxes[i].max.cwiseMin(boxes[j].max);
        EXPECT_FALSE((lo.array() < hi.array()).all()) << "boxes " << i << " and " << j;
      }
    }
    for (const auto& s : scene.spheres()) {
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        AnalyticScene one("one");
        one.add_box(boxes[i].min, boxes[i].max);
        EXPECT_GE(one.signed_distance(s.centre), s.radius - 1e-12) << "box " << i;
      }
    }
  }
  // The corner's sphere rests on the floor, touching it at exactly one point.
  const AnalyticScene corner = AnalyticScene::make("corner");
  ASSERT_EQ(corner.spheres().size(), 1u);
  const SceneSphere& ball = corner.spheres()[0];
  EXPECT_DOUBLE_EQ(ball.centre.z(), ball.radius);
  EXPECT_GE(ball.radius, 0.15);
  EXPECT_LE(ball.radius, 0.25);
}

TEST(AnalyticScene, UnknownNameIsAUsageError) {
  try {
    AnalyticScene::make("kitchen");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    const std::string message = e.what();
    EXPECT_NE(message.find("kitchen"), std::string::npos) << message;
    EXPECT_NE(message.find("corner"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace aoscan
