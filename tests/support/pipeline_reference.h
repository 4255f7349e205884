/// @file pipeline_reference.h
/// @brief Plain serial versions of the pipeline's view products, the oracles of its tests.
#pragma once

#include "ao/mvao_grid.h"
#include "core/image.h"
#include "core/pose.h"
#include "geometry/point_maps.h"

namespace aoscan::test {

/// The plain serial version of mvao_image (pipeline/view_products.h): AO of the MVAO grid cell
/// holding each pixel's world point T_world_camera * maps.vertices(x, y), in [0, 1]; NaN where the
/// pixel has no surface (zero vertex) or its cell was never observed.
void mvao_image_reference(const MvaoGrid& grid, const PointMaps& maps, const Pose& T_world_camera,
                          Image<float>& out);

/// The plain serial version of the coarse mvao_image (ao.view_read coarse): the grid coarsened by
/// MvaoGrid::kBrickSide, sampled trilinearly at each pixel's world point; NaN where the pixel has
/// no surface or no coarse cell around its point is observed.
void mvao_image_coarse_reference(const MvaoGrid& grid, const PointMaps& maps,
                                 const Pose& T_world_camera, Image<float>& out);

}  // namespace aoscan::test
