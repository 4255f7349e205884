/// @file point_cloud_ply.h
/// @brief Writing point clouds as binary little-endian PLY (float x y z, optionally float nx ny
/// nz; no faces, no colour) point by point, so that a cloud of any size is written without being
/// held in memory. `read_ply()` (io/ply.h) reads them.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace aoscan {

/// The header of a cloud of `count` points: `ply`, `format binary_little_endian 1.0`,
/// `element vertex COUNT`, `property float x`, `y`, `z` (and `nx`, `ny`, `nz` when `normals`),
/// `end_header`; the data follows directly.
std::string point_cloud_ply_header(std::int64_t count, bool normals);

/// Writes one cloud whose point count is known before its points are: the header on
/// construction, then each point as it comes (buffered), checked against the count on close().
/// Write it to an output through write_atomically() (io/atomic_write.h).
class PointCloudPlyWriter {
 public:
  /// Creates `path` and writes the header. Throws usage_error for a negative count and
  /// Error(kFailure) naming the file when it cannot be created.
  PointCloudPlyWriter(const std::string& path, std::int64_t count, bool normals);
  ~PointCloudPlyWriter();  ///< closes the file if close() was not called (no error reported)
  PointCloudPlyWriter(const PointCloudPlyWriter&) = delete;
  PointCloudPlyWriter& operator=(const PointCloudPlyWriter&) = delete;

  /// Appends a point (metres) and its normal (ignored without normals). Throws Error(kFailure)
  /// naming the file on a write failure or a point beyond the announced count.
  void add(const Eigen::Vector3f& p, const Eigen::Vector3f& n = Eigen::Vector3f::Zero());
  /// Writes what is buffered and closes the file. Throws Error(kFailure) naming the file when a
  /// write failed or fewer points than announced were added.
  void close();

 private:
  void flush();

  std::string path_;
  std::FILE* file_ = nullptr;
  std::int64_t count_ = 0;
  std::int64_t added_ = 0;
  bool normals_ = false;
  std::vector<unsigned char> buffer_;
};

}  // namespace aoscan
