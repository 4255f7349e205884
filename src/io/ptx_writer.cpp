/// @file ptx_writer.cpp
/// @brief Writing PTX scans.
#include "io/ptx_writer.h"

#include <charconv>
#include <cmath>
#include <cstring>

#include "core/checked_close.h"
#include "core/status.h"

namespace aoscan {
namespace {

constexpr std::size_t kBufferBytes = 1 << 20;

/// `v` into `out` (room for 64 characters) in the shortest form that reads back as `v` through a
/// double (std::from_chars as double, then narrowed, as read_ptx() does): the float's shortest
/// form, unless that narrows differently (a decimal that lies within a double's rounding of the
/// midpoint between two floats), then the double's. Returns the end.
char* put_float(char* out, float v) {
  char* end = std::to_chars(out, out + 64, v).ptr;
  double back = 0.0;
  std::from_chars(out, end, back);
  if (static_cast<float>(back) != v) end = std::to_chars(out, out + 64, static_cast<double>(v)).ptr;
  return end;
}

}  // namespace

PtxWriter::PtxWriter(const std::string& path) : path_(path), file_(std::fopen(path.c_str(), "wb")) {
  if (!file_) throw_write_failed(path_);
  buffer_.reserve(kBufferBytes + 512);
}

PtxWriter::~PtxWriter() {
  if (file_) std::fclose(file_);
}

void PtxWriter::put(const char* text, std::size_t n) {
  buffer_.insert(buffer_.end(), text, text + n);
  if (buffer_.size() >= kBufferBytes) flush();
}

void PtxWriter::flush() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    throw_write_failed(path_);
  buffer_.clear();
}

void PtxWriter::begin_scan(int columns, int rows, const Pose& T_world_scanner) {
  if (!file_) throw Error(ExitCode::kFailure, path_ + ": PTX file already closed");
  if (columns < 1 || rows < 1)
    throw usage_error(path_ + ": a PTX scan needs at least one column and one row");
  if (cells_left_ != 0)
    throw Error(ExitCode::kFailure,
                path_ + ": the previous scan misses " + std::to_string(cells_left_) + " cells");
  cells_left_ = static_cast<std::int64_t>(columns) * rows;
  const Eigen::Matrix3d& R = T_world_scanner.rotation();
  const Eigen::Vector3d& t = T_world_scanner.translation();
  char line[256];
  auto row3 = [&](const Eigen::Vector3d& v) {
    put(line, static_cast<std::size_t>(
                  std::snprintf(line, sizeof line, "%.17g %.17g %.17g\n", v.x(), v.y(), v.z())));
  };
  auto row4 = [&](const Eigen::Vector3d& v, int w) {
    put(line, static_cast<std::size_t>(std::snprintf(line, sizeof line, "%.17g %.17g %.17g %d\n",
                                                     v.x(), v.y(), v.z(), w)));
  };
  put(line, static_cast<std::size_t>(std::snprintf(line, sizeof line, "%d\n%d\n", columns, rows)));
  row3(t);
  for (int c = 0; c < 3; ++c) row3(R.col(c));
  for (int c = 0; c < 3; ++c) row4(R.col(c), 0);
  row4(t, 1);
}

void PtxWriter::next_cell() {
  if (!file_) throw Error(ExitCode::kFailure, path_ + ": PTX file already closed");
  if (cells_left_ == 0) throw Error(ExitCode::kFailure, path_ + ": a cell beyond the scan's grid");
  --cells_left_;
}

void PtxWriter::add(const Eigen::Vector3f& p, float intensity) {
  next_cell();
  char line[4 * 64 + 4];
  char* at = line;
  for (int k = 0; k < 3; ++k) {
    at = put_float(at, p[k]);
    *at++ = ' ';
  }
  at = put_float(at, intensity);
  *at++ = '\n';
  put(line, static_cast<std::size_t>(at - line));
}

void PtxWriter::add_missing() {
  next_cell();
  put("0 0 0 0\n", 8);
}

void PtxWriter::close() {
  if (!file_) return;
  flush();
  close_checked(file_, path_);
  if (cells_left_ != 0)
    throw Error(ExitCode::kFailure,
                path_ + ": the last scan misses " + std::to_string(cells_left_) + " cells");
}

}  // namespace aoscan
