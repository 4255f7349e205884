/// @file ptx_writer.h
/// @brief Writing PTX files, the laser scanners' ASCII exchange format that io/ptx.h reads: one or
/// more structured scans, each a header and its columns x rows grid of points, written cell by
/// cell so that a file of any size is written without holding a scan.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/pose.h"

namespace aoscan {

/// Writes a PTX file scan by scan. A scan's header holds its grid size, the scanner's registered
/// position and axes (the translation and the columns of T_world_scanner's rotation) and the
/// 4 x 4 registration written transposed, as PTX does (the translation in the last row); doubles
/// with 17 significant digits. Each cell is a line `x y z intensity` in the scanner frame with
/// each float in its shortest form that reads back as the same float (through a double, as
/// read_ptx() reads it); a cell without a return is `0 0 0 0`. PTX's cell order is column by
/// column, each column's rows in turn. Write it to an output through write_atomically()
/// (io/atomic_write.h).
class PtxWriter {
 public:
  /// Creates `path`; throws Error(kFailure) naming it when it cannot be created.
  explicit PtxWriter(const std::string& path);
  ~PtxWriter();  ///< closes the file if close() was not called (no error reported)
  PtxWriter(const PtxWriter&) = delete;
  PtxWriter& operator=(const PtxWriter&) = delete;

  /// Starts a scan of `columns` x `rows` cells (both at least 1) registered by `T_world_scanner`.
  /// Throws usage_error for a bad size and Error(kFailure) when the previous scan is incomplete.
  void begin_scan(int columns, int rows, const Pose& T_world_scanner);
  /// The next cell: a point (scanner frame, metres; not the origin, which PTX reads as no
  /// return) and its intensity.
  void add(const Eigen::Vector3f& p, float intensity);
  /// The next cell, without a return.
  void add_missing();
  /// Writes what is buffered and closes the file. Throws Error(kFailure) naming the file when a
  /// write failed or the last scan is incomplete.
  void close();

 private:
  void next_cell();
  void put(const char* text, std::size_t n);
  void flush();

  std::string path_;
  std::FILE* file_ = nullptr;
  std::int64_t cells_left_ = 0;
  std::vector<char> buffer_;
};

}  // namespace aoscan
