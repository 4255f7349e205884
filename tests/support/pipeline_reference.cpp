/// @file pipeline_reference.cpp
/// @brief The serial MVAO images (per cell and coarse).
#include "support/pipeline_reference.h"

#include <limits>
#include <optional>

namespace aoscan::test {

void mvao_image_reference(const MvaoGrid& grid, const PointMaps& maps, const Pose& T_world_camera,
                          Image<float>& out) {
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  out.resize(maps.vertices.width(), maps.vertices.height());
  const Eigen::Matrix3d& R = T_world_camera.rotation();
  const Eigen::Vector3d& t = T_world_camera.translation();
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) {
      const Eigen::Vector3f& v = maps.vertices(x, y);
      out(x, y) = kNan;
      if (v.isZero()) continue;
      const std::optional<CellIndex> cell = grid.cell_of(R * v.cast<double>() + t);
      if (!cell) continue;
      if (const std::optional<float> value = grid.cell_ao(*cell)) out(x, y) = *value;
    }
  }
}

void mvao_image_coarse_reference(const MvaoGrid& grid, const PointMaps& maps,
                                 const Pose& T_world_camera, Image<float>& out) {
  const MvaoGrid coarse = grid.coarsened(MvaoGrid::kBrickSide);
  out.resize(maps.vertices.width(), maps.vertices.height());
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) {
      const Eigen::Vector3f& v = maps.vertices(x, y);
      out(x, y) = std::numeric_limits<float>::quiet_NaN();
      if (v.isZero()) continue;
      const std::optional<float> value = coarse.sample(
          T_world_camera.rotation() * v.cast<double>() + T_world_camera.translation());
      if (value) out(x, y) = *value;
    }
  }
}

}  // namespace aoscan::test
