// Tests for src/fusion/marching_cubes.cpp: the generated case table, an analytic sphere written
// into the volume (accuracy, closedness, orientation, genus), the serial reference, determinism
// across threads and allocation orders, weight threshold, a fused plane.
#include "fusion/tsdf/marching_cubes.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <utility>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "fusion/tsdf/tsdf_integrator.h"
#include "support/test_scenes.h"
#include "support/tsdf_reference.h"

namespace aoscan {
namespace {

const Eigen::Vector3d kCentre(0.013, -0.021, 0.007);
constexpr double kRadius = 0.2;

/// Writes the exact truncated SDF of a sphere into every block within reach of its surface;
/// `reverse` allocates the blocks in the opposite order.
void write_sphere(TsdfVolume& volume, bool reverse = false) {
  const double vs = volume.voxel_size_m();
  const double trunc = volume.truncation_m();
  const int reach = static_cast<int>(std::ceil((kRadius + 2 * trunc) / volume.block_size_m())) + 1;
  std::vector<Eigen::Vector3i> blocks;
  for (int z = -reach; z <= reach; ++z)
    for (int y = -reach; y <= reach; ++y)
      for (int x = -reach; x <= reach; ++x) {
        const Eigen::Vector3d centre =
            (Eigen::Vector3d(x, y, z) * kBlockSize + Eigen::Vector3d::Constant(3.5)) * vs;
        const double sd = (centre - kCentre).norm() - kRadius;
        if (std::abs(sd) < trunc + volume.block_size_m()) blocks.emplace_back(x, y, z);
      }
  if (reverse) std::reverse(blocks.begin(), blocks.end());
  for (const Eigen::Vector3i& b : blocks) {
    const int i = volume.allocate_block(b);
    ASSERT_GE(i, 0);
    for (int z = 0; z < kBlockSize; ++z)
      for (int y = 0; y < kBlockSize; ++y)
        for (int x = 0; x < kBlockSize; ++x) {
          const Eigen::Vector3d p = (b * kBlockSize + Eigen::Vector3i(x, y, z)).cast<double>() * vs;
          const double sd = (p - kCentre).norm() - kRadius;
          volume.block(i).voxels[voxel_index(x, y, z)].store(static_cast<float>(sd / trunc), 5.0f);
        }
  }
}

TEST(MarchingCubes, TableCutsExactlyTheSignChanges) {
  const MarchingCubesTable& table = marching_cubes_table();
  EXPECT_TRUE(table.triangles[0].empty());
  EXPECT_TRUE(table.triangles[255].empty());
  for (int mask = 1; mask < 255; ++mask) {
    std::set<int> used;
    for (const auto& t : table.triangles[mask]) used.insert(t.begin(), t.end());
    for (int e = 0; e < 12; ++e) {
      const bool crossing = ((mask >> kCubeEdges[e][0]) & 1) != ((mask >> kCubeEdges[e][1]) & 1);
      EXPECT_EQ(crossing, used.count(e) == 1) << "case " << mask << " edge " << e;
    }
  }
  // One inside corner: one triangle whose normal points away from it.
  ASSERT_EQ(table.triangles[1].size(), 1u);
}

TEST(MarchingCubes, SphereIsAccurateClosedAndOutwardOriented) {
  TsdfVolume volume{FusionConfig{}};
  write_sphere(volume);
  const TriangleMesh mesh = extract_mesh(volume, 1.0f);
  ASSERT_FALSE(mesh.empty());
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  const double vs = volume.voxel_size_m();
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3d p = mesh.vertices[i].cast<double>();
    ASSERT_NEAR((p - kCentre).norm(), kRadius, 0.05 * vs);
    const double c = mesh.normals[i].cast<double>().dot((p - kCentre).normalized());
    ASSERT_GT(c, std::cos(2.0 * M_PI / 180.0));
  }
  // Closed and consistently oriented: every directed edge once, and its reverse once.
  std::map<std::pair<int, int>, int> directed;
  double volume6 = 0;
  for (const Eigen::Vector3i& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
    const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>() - kCentre;
    const Eigen::Vector3d b = mesh.vertices[f[1]].cast<double>() - kCentre;
    const Eigen::Vector3d c = mesh.vertices[f[2]].cast<double>() - kCentre;
    volume6 += a.dot(b.cross(c));
  }
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1);
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u);
  }
  const long long v = static_cast<long long>(mesh.vertices.size());
  const long long e = static_cast<long long>(directed.size() / 2);
  const long long f = static_cast<long long>(mesh.faces.size());
  EXPECT_EQ(v - e + f, 2);  // a sphere
  EXPECT_NEAR(volume6 / 6.0, 4.0 / 3.0 * M_PI * std::pow(kRadius, 3), 0.002);
}

/// Triangles as sorted triples of vertex positions (exact floats), for order-free comparison.
std::multiset<std::array<float, 9>> triangle_set(const TriangleMesh& mesh) {
  std::multiset<std::array<float, 9>> set;
  for (const Eigen::Vector3i& f : mesh.faces) {
    std::array<std::array<float, 3>, 3> corners;
    for (int k = 0; k < 3; ++k)
      corners[k] = {mesh.vertices[f[k]].x(), mesh.vertices[f[k]].y(), mesh.vertices[f[k]].z()};
    // Rotate so the smallest corner comes first (keeps the winding).
    const int first =
        static_cast<int>(std::min_element(corners.begin(), corners.end()) - corners.begin());
    std::array<float, 9> key;
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) key[3 * k + d] = corners[(first + k) % 3][d];
    set.insert(key);
  }
  return set;
}

TEST(MarchingCubes, ParallelExtractionMatchesSerialReference) {
  TsdfVolume volume{FusionConfig{}};
  write_sphere(volume);
  const TriangleMesh fast = extract_mesh(volume, 1.0f);
  const TriangleMesh reference = test::extract_mesh_reference(volume, 1.0f);
  EXPECT_EQ(fast.vertices.size(), reference.vertices.size());
  EXPECT_EQ(fast.faces.size(), reference.faces.size());
  EXPECT_TRUE(triangle_set(fast) == triangle_set(reference));
}

bool same_bytes(const TriangleMesh& a, const TriangleMesh& b) {
  auto eq = [](const auto& x, const auto& y) {
    return x.size() == y.size() &&
           (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
  };
  return eq(a.vertices, b.vertices) && eq(a.normals, b.normals) && eq(a.faces, b.faces);
}

TEST(MarchingCubes, DeterministicAcrossThreadsAndAllocationOrder) {
  TsdfVolume volume{FusionConfig{}}, reversed{FusionConfig{}};
  write_sphere(volume);
  write_sphere(reversed, true);
  TriangleMesh one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = extract_mesh(volume, 1.0f);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = extract_mesh(volume, 1.0f);
  }
  EXPECT_TRUE(same_bytes(one, two));
  EXPECT_TRUE(same_bytes(one, extract_mesh(reversed, 1.0f)));
}

TEST(MarchingCubes, WeightThresholdAndEmptyVolume) {
  TsdfVolume volume{FusionConfig{}};
  EXPECT_TRUE(extract_mesh(volume, 1.0f).empty());
  write_sphere(volume);
  EXPECT_TRUE(extract_mesh(volume, 6.0f).empty());  // every voxel has weight 5
  EXPECT_FALSE(extract_mesh(volume, 5.0f).empty());
}

TEST(MarchingCubes, FusedPlaneLiesOnThePlane) {
  const Intrinsics k{640, 480, 585.0, 585.0, 320.0, 240.0};
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), 1.3});
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  Image<float> depth;
  test::render(scene, k, Pose::identity(), depth);
  integrator.integrate(volume, depth, k, Pose::identity());
  const TriangleMesh mesh = extract_mesh(volume, 1.0f);
  ASSERT_GT(mesh.faces.size(), 10000u);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    ASSERT_NEAR(mesh.vertices[i].z(), 1.3, 1e-4);
    ASSERT_NEAR(mesh.normals[i].z(), -1.0, 1e-3);  // facing the camera at the origin
  }
}

}  // namespace
}  // namespace aoscan
