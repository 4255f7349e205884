/// @file mesh_ao.h
/// @brief Per-vertex AO of a triangle mesh from the MVAO grid (the `quality` of mesh.ply).
#pragma once

#include <cstddef>

#include "ao/mvao_grid.h"
#include "core/mesh.h"

namespace aoscan {

/// Sets mesh.quality (one per vertex, in [0, 1], never NaN) from grid.coarsened(mesh_cell_factor)
/// (ao.mesh_cell_factor; the grid itself for a factor of 1 or less) through apply_grid_ao_cells().
std::size_t apply_grid_ao(const MvaoGrid& grid, int mesh_cell_factor, TriangleMesh& mesh);

/// Sets mesh.quality (one per vertex, in [0, 1], never NaN) from `grid`'s own cells: the trilinear
/// sample at the vertex (world frame, metres); where none of the 8 surrounding cells was observed
/// the AO of the observed cell whose centre is nearest (1.0 for a non-finite vertex); 1.0 for
/// every vertex when the grid holds no cell at all. Returns the number of vertices that needed
/// the fallback (all of them for an empty grid): stats.json's mesh.ao_unobserved_vertices.
std::size_t apply_grid_ao_cells(const MvaoGrid& grid, TriangleMesh& mesh);

}  // namespace aoscan
