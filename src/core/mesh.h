/// @file mesh.h
/// @brief An indexed triangle mesh with optional per-vertex normals and AO (`quality`).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "core/colour.h"

namespace aoscan {

/// Triangle mesh in metres. `normals`, `quality` and `colours` are either empty or one per
/// vertex; quality is the AO in [0, 1] (1 = fully open), colours the fused colour.
struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3f> normals;
  std::vector<float> quality;
  std::vector<Rgb8> colours;
  std::vector<Eigen::Vector3i> faces;

  bool empty() const { return vertices.empty(); }
};

}  // namespace aoscan
