/// @file vdb.h
/// @brief Sparse TSDF volumes as OpenVDB files (`volume.vdb`): a float grid `tsdf` (signed
/// distance in metres) and a float grid `weight`, and with colour a vector grid `Cd` and a float
/// grid `colour_weight`, in a neutral brick layout so that io does not depend on fusion.
/// OpenVDB's headers stay inside vdb.cpp.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/colour.h"

namespace aoscan {

/// Voxels per brick edge; equals OpenVDB's leaf node (and fusion's block) edge.
inline constexpr int kBrickSize = 8;
inline constexpr int kBrickVoxels = kBrickSize * kBrickSize * kBrickSize;

/// One 8^3 brick of a sparse volume. Voxel (x, y, z) of the brick (0..7 each) is entry
/// x + 8 * (y + 8 * z) and has global voxel coordinates origin + (x, y, z); the centre of global
/// voxel g lies at g * voxel_size_m in the world frame (metres).
struct VolumeBrick {
  Eigen::Vector3i origin = Eigen::Vector3i::Zero();  ///< voxel (0, 0, 0); each a multiple of 8
  std::array<float, kBrickVoxels> sdf_m{};           ///< signed distance (m), positive in front
  std::array<float, kBrickVoxels> weight{};          ///< observations; 0 = never observed
  /// The fused colour (only when the volume has colour) and its observations; 0 = no colour.
  std::array<Rgb8, kBrickVoxels> colour{};
  std::array<std::uint8_t, kBrickVoxels> colour_weight{};
};

/// A sparse volume seen brick by brick, so that a writer never needs a copy of it.
struct VolumeView {
  double voxel_size_m = 0.0;  ///< voxel edge (m)
  double truncation_m = 0.0;  ///< truncation band (m): the value of unobserved voxels
  std::size_t brick_count = 0;
  bool has_colour = false;  ///< the bricks carry colour (written as the grids Cd and colour_weight)
  /// Fills `brick` with brick number `index` (0 .. brick_count - 1). Bricks may come in any
  /// order; two bricks must not share an origin.
  std::function<void(std::size_t index, VolumeBrick& brick)> brick;
};

/// What write_volume_vdb() wrote.
struct VdbWriteStats {
  std::size_t bricks = 0;         ///< bricks with at least one observed voxel (OpenVDB leaves)
  std::size_t active_voxels = 0;  ///< observed voxels (weight > 0)
  std::uintmax_t file_bytes = 0;
};

/// Writes `volume` to `path` as an OpenVDB file with two FloatGrids sharing one linear transform
/// of voxel size voxel_size_m (index voxel g <-> world point g * voxel_size_m, world frame and
/// metres of the volume, i.e. of trajectory.txt):
/// - `tsdf`: class level set, background +truncation_m; active voxels = the observed ones
///   (weight > 0) with their signed distance in metres; grid metadata `truncation_m` (float).
/// - `weight`: class unknown, background 0; the same active voxels with their weight.
/// - with colour (has_colour, and some voxel of an observed one coloured): `Cd` (Vec3SGrid, the
///   colour attribute's name in Houdini and other VDB tools), RGB in [0, 1] = byte / 255, and
///   `colour_weight` (FloatGrid), its observations; active voxels = the observed voxels that have
///   colour. Without colour the file is exactly as without these grids.
/// Unobserved voxels are inactive (background). The bytes depend only on the voxel values, not on
/// the brick order or thread count: OpenVDB's random file UUID is replaced by one derived from the
/// content. Throws usage_error for a non-positive voxel size or truncation, a brick origin that is
/// not a multiple of 8 or a repeated one, and Error (exit code 1) naming the file when it cannot
/// be written.
VdbWriteStats write_volume_vdb(const std::string& path, const VolumeView& volume);

/// A volume read back from a volume.vdb.
struct VolumeData {
  double voxel_size_m = 0.0;
  double truncation_m = 0.0;
  bool has_colour = false;  ///< the file has the grids Cd and colour_weight
  /// Bricks with at least one active voxel, ordered by origin (z, then y, then x); inactive voxels
  /// have weight 0 and sdf_m = truncation_m; voxels without colour have colour_weight 0.
  std::vector<VolumeBrick> bricks;
};

/// Reads a file written by write_volume_vdb() (or any OpenVDB file with float grids `tsdf` and
/// `weight` on the same uniform, axis-aligned, unrotated transform; `Cd` and `colour_weight`
/// when present, both or neither, colour rounded back to bytes). Throws input_error naming the
/// file when it is missing or unreadable, lacks a grid, or the grids disagree in transform.
VolumeData read_volume_vdb(const std::string& path);

}  // namespace aoscan
