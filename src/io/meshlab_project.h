/// @file meshlab_project.h
/// @brief MeshLab projects (`.mlp`): the layers of a registered scan set, each a point cloud file
/// with its 4 x 4 registration (the paper's own scans were registered in MeshLab).
#pragma once

#include <string>
#include <vector>

#include "io/scan_manifest.h"

namespace aoscan {

/// Reads the `MLMesh` layers of a MeshLab project: each becomes a point-cloud scan (its
/// `filename`, resolved against the project's folder, must be a PLY), named by its `label` (else
/// the file's stem), posed by its `MLMatrix44` (row-major; identity when absent), with the
/// scanner at the origin of the layer's own frame (scanner software exports each scan in its
/// scanner's frame). Throws input_error naming the project on a file that is not a MeshLab
/// project, a layer without a file, a missing or non-PLY file, a matrix that is not 16 numbers
/// of a rigid transform, or two layers with one name.
std::vector<ScanEntry> read_meshlab_project(const std::string& path);

}  // namespace aoscan
