/// @file mesh_ao_test.cpp
/// @brief Tests for src/ao/mesh_ao.h: trilinear per-vertex AO, nearest-cell fallback and its
/// count and its ties, the empty grid, non-finite vertices.
#include "ao/mesh_ao.h"

#include <cmath>

#include <gtest/gtest.h>

namespace aoscan {
namespace {

/// A grid with cell size 0.25 m (mean integration) holding 0.2 in cell (0,0,0) and `second_ao`
/// in the cell of `second` (by default cell (8,0,0) = 0.8); `second_first`: the second point is
/// the first pixel, so the grid meets its cell first.
MvaoGrid two_cell_grid(const Eigen::Vector3f& second = {2.1f, 0.1f, 0.1f}, float second_ao = 0.8f,
                       bool second_first = false) {
  AoConfig c;
  c.grid_extent_m = 1.0;
  c.grid_resolution = 4;
  c.integration = AoIntegration::kMean;
  MvaoGrid grid(c);
  Image<float> ao(2, 1), w(2, 1, 1.0f);
  const int a = second_first ? 1 : 0;
  ao(a, 0) = 0.2f;
  ao(1 - a, 0) = second_ao;
  PointMaps maps;
  maps.vertices.resize(2, 1, Eigen::Vector3f::Zero());
  maps.normals.resize(2, 1, Eigen::Vector3f(0.0f, 0.0f, -1.0f));
  maps.vertices(a, 0) = Eigen::Vector3f(0.1f, 0.1f, 0.1f);
  maps.vertices(1 - a, 0) = second;
  grid.integrate(ao, w, maps, Pose::identity());
  return grid;
}

TEST(MeshAo, SamplesTheGridAndFallsBackToTheNearestCell) {
  const MvaoGrid grid = two_cell_grid();
  TriangleMesh mesh;
  mesh.vertices = {{0.125f, 0.125f, 0.125f},  // centre of cell 0
                   {2.2f, 0.1f, 0.15f},       // inside cell 8's neighbourhood
                   {0.9f, 0.125f, 0.125f},    // unobserved; nearest centre is cell 0 (0.775 m)
                   {1.5f, 0.125f, 0.125f},    // unobserved; nearest centre is cell 8 (0.625 m)
                   {40.0f, -30.0f, 10.0f},    // far away: nearest is cell 8
                   {std::nanf(""), 0.0f, 0.0f}};
  mesh.faces = {{0, 1, 2}, {3, 4, 5}};
  EXPECT_EQ(apply_grid_ao(grid, 1, mesh), 4u);  // the grid's own cells
  ASSERT_EQ(mesh.quality.size(), mesh.vertices.size());
  EXPECT_FLOAT_EQ(mesh.quality[0], 0.2f);
  EXPECT_FLOAT_EQ(mesh.quality[1], 0.8f);
  EXPECT_FLOAT_EQ(mesh.quality[2], 0.2f);
  EXPECT_FLOAT_EQ(mesh.quality[3], 0.8f);
  EXPECT_FLOAT_EQ(mesh.quality[4], 0.8f);
  EXPECT_FLOAT_EQ(mesh.quality[5], 1.0f);
}

TEST(MeshAo, EquallyNearCellsGoToTheSmallestCentreWhateverTheGridsOrder) {
  // Cells (0,0,0) = 0.2 and (8,0,0) = 0.8 (in different buckets of the search), the vertex
  // exactly between their centres: the same answer whichever cell the grid met first.
  for (bool swapped : {false, true}) {
    const MvaoGrid grid = two_cell_grid({2.1f, 0.1f, 0.1f}, 0.8f, swapped);
    TriangleMesh mesh;
    mesh.vertices = {{1.125f, 0.125f, 0.125f}};
    EXPECT_EQ(apply_grid_ao(grid, 1, mesh), 1u);
    EXPECT_FLOAT_EQ(mesh.quality[0], 0.2f) << (swapped ? "cell 8 integrated first" : "");
  }
}

TEST(MeshAo, ReadsTheGridThroughCoarserCellsWithTheMeshCellFactor) {
  // Cells (0,0,0) = 0.2 and (1,0,0) = 0.6 share the coarse cell (0,0,0) of factor 2: mean 0.4.
  const MvaoGrid grid = two_cell_grid({0.3f, 0.1f, 0.1f}, 0.6f);
  TriangleMesh mesh;
  mesh.vertices = {{0.125f, 0.125f, 0.125f}, {0.25f, 0.25f, 0.25f}};
  EXPECT_EQ(apply_grid_ao(grid, 2, mesh), 0u);
  EXPECT_FLOAT_EQ(mesh.quality[0], 0.4f);
  EXPECT_FLOAT_EQ(mesh.quality[1], 0.4f);
  // The grid's own cells: cell (0,0,0)'s centre gives its own value.
  EXPECT_EQ(apply_grid_ao_cells(grid, mesh), 0u);
  EXPECT_FLOAT_EQ(mesh.quality[0], 0.2f);
}

TEST(MeshAo, EmptyGridGivesOpenVertices) {
  AoConfig c;
  const MvaoGrid grid(c);
  TriangleMesh mesh;
  mesh.vertices = {{0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}};
  mesh.quality = {0.3f};  // stale values are replaced
  EXPECT_EQ(apply_grid_ao(grid, c.mesh_cell_factor, mesh), 3u);
  EXPECT_EQ(mesh.quality, std::vector<float>(3, 1.0f));
  TriangleMesh none;
  EXPECT_EQ(apply_grid_ao(grid, c.mesh_cell_factor, none), 0u);
  EXPECT_TRUE(none.quality.empty());
}

}  // namespace
}  // namespace aoscan
