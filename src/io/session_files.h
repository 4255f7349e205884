/// @file session_files.h
/// @brief The binary files of a saved session (`OUT/session/`): the relocalisation keyframes and
/// the MVAO grid's cells, as neutral records (io does not depend on fusion or ao). Each file is a
/// magic, a format version, its records and a 64-bit FNV-1a checksum of everything before it, so
/// that a truncated or damaged file is refused, never half read.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"

namespace aoscan {

/// The format version of the session files (and of session.json): a session written by another
/// version is refused.
inline constexpr std::uint32_t kSessionFormatVersion = 1;

/// One keyframe: fern codes, camera-to-world pose, coarse depth (mm).
struct SavedKeyframe {
  std::vector<std::uint8_t> codes;
  Eigen::Matrix4d T_world_camera = Eigen::Matrix4d::Identity();
  Image<std::uint16_t> depth_mm;
};

struct SavedKeyframes {
  std::uint32_t ferns = 0, fern_decisions = 0;
  std::vector<SavedKeyframe> keyframes;
};

/// Writes `keyframes` to `path` atomically. Throws Error (exit code 1) naming the file when it
/// cannot be written.
void write_keyframes(const std::string& path, const SavedKeyframes& keyframes);

/// Reads a file of write_keyframes(). At most `max_keyframes` are accepted: a larger database is
/// refused before its keyframes are read. Throws input_error naming the file when it is missing,
/// truncated, damaged (checksum), of another format version, holds codes wider than its decisions
/// or a non-finite or non-rigid pose.
SavedKeyframes read_keyframes(const std::string& path, std::size_t max_keyframes);

/// One observed MVAO grid cell.
struct SavedCell {
  std::int32_t x = 0, y = 0, z = 0;
  float ao_weight_sum = 0.0f, weight_sum = 0.0f;
  std::uint32_t last_frame = 0;
};

struct SavedGrid {
  double cell_size_m = 0.0;
  std::uint32_t integration = 0;  ///< the grid's merge mode (ao's AoIntegration as a number)
  std::uint64_t frames = 0;       ///< frames integrated
  std::vector<SavedCell> cells;
};

/// Writes `grid` to `path` atomically; throws like write_keyframes().
void write_grid(const std::string& path, const SavedGrid& grid);

/// Reads a file of write_grid(); throws input_error naming the file when it is missing,
/// truncated, damaged, of another version, or holds a non-finite or negative weight.
SavedGrid read_grid(const std::string& path);

}  // namespace aoscan
