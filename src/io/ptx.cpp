/// @file ptx.cpp
/// @brief Reading PTX laser scans.
#include "io/ptx.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>

#include "core/status.h"

namespace aoscan {
namespace {

/// Reads whitespace-separated numbers line by line, counting lines for messages.
class LineReader {
 public:
  explicit LineReader(const std::string& path) : path_(path), in_(path) {
    if (!in_) throw input_error(path + ": cannot open PTX file");
  }

  /// Reads the next non-empty line into `values` (between min_count and max_count numbers, each
  /// finite unless `any_number`, where nan and inf parse too); false at the end of the file.
  bool next(std::vector<double>& values, std::size_t min_count, std::size_t max_count,
            bool any_number = false) {
    std::string line;
    while (std::getline(in_, line)) {
      ++line_number_;
      values.clear();
      const char* p = line.data();
      const char* end = p + line.size();
      for (;;) {
        while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
        if (p == end) break;
        double v = 0.0;
        const auto r = std::from_chars(p, end, v);
        if (r.ec != std::errc() || !(any_number || std::isfinite(v))) fail("not a number");
        values.push_back(v);
        p = r.ptr;
      }
      if (values.empty()) continue;
      if (values.size() < min_count || values.size() > max_count)
        fail("expected " + std::to_string(min_count) +
             (max_count > min_count ? " to " + std::to_string(max_count) : std::string()) +
             " numbers, found " + std::to_string(values.size()));
      return true;
    }
    if (in_.bad()) throw input_error(path_ + ": cannot read PTX file");
    return false;
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw input_error(path_ + ":" + std::to_string(line_number_) + ": " + what);
  }

 private:
  std::string path_;
  std::ifstream in_;
  long long line_number_ = 0;
};

/// The 4 x 4 registration of a PTX header: PTX writes the matrix transposed (the translation in
/// the last row).
Pose registration(const double m[16], const LineReader& reader) {
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T(c, r) = m[4 * r + c];
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if ((T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6 ||
      (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-4 || R.determinant() < 0.0)
    reader.fail("the registration matrix is not a rigid transform");
  return Pose::from_matrix(T).normalized();
}

}  // namespace

std::size_t read_ptx(const std::string& path, const std::function<void(PtxScan&&)>& each) {
  LineReader reader(path);
  std::size_t count = 0;
  std::vector<double> v;
  while (reader.next(v, 1, 1)) {
    PtxScan scan;
    const double columns = v[0];
    if (!reader.next(v, 1, 1)) reader.fail("the file ends inside a scan header");
    const double rows = v[0];
    if (!(columns >= 1 && rows >= 1 && columns == std::floor(columns) &&
          rows == std::floor(rows) && columns <= 1e9 && rows <= 1e9 && columns * rows <= 1e10))
      reader.fail("the grid size must be two positive whole numbers");
    scan.columns = static_cast<int>(columns);
    scan.rows = static_cast<int>(rows);
    for (int i = 0; i < 4; ++i)  // scanner position and axes: the matrix below says the same
      if (!reader.next(v, 3, 3)) reader.fail("the file ends inside a scan header");
    double m[16];
    for (int r = 0; r < 4; ++r) {
      if (!reader.next(v, 4, 4)) reader.fail("the file ends inside a scan header");
      for (int c = 0; c < 4; ++c) m[4 * r + c] = v[c];
    }
    scan.T_world_scanner = registration(m, reader);
    const long long cells = static_cast<long long>(scan.columns) * scan.rows;
    for (long long i = 0; i < cells; ++i) {
      // A point's numbers may be nan or inf (what some exporters write for a cell without a
      // return): the point is kept as read, and the rasteriser skips and counts it.
      if (!reader.next(v, 4, 7, true))
        reader.fail("the file ends after " + std::to_string(i) + " of the scan's " +
                    std::to_string(cells) + " points");
      if (v.size() == 5 || v.size() == 6) reader.fail("a point is x y z intensity [r g b]");
      if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) {
        ++scan.missing;
        continue;
      }
      scan.points.emplace_back(static_cast<float>(v[0]), static_cast<float>(v[1]),
                               static_cast<float>(v[2]));
    }
    ++count;
    each(std::move(scan));
  }
  if (count == 0) throw input_error(path + ": the PTX file holds no scan");
  return count;
}

std::vector<PtxScan> read_ptx(const std::string& path) {
  std::vector<PtxScan> scans;
  read_ptx(path, [&scans](PtxScan&& scan) { scans.push_back(std::move(scan)); });
  return scans;
}

}  // namespace aoscan
