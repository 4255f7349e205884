/// @file tum.cpp
/// @brief TUM file lists and trajectories: parsing with line-numbered errors, deterministic
/// writing.
#include "io/tum.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string_view>

#include "core/status.h"
#include "io/atomic_write.h"
#include "io/tokens.h"

namespace aoscan {
namespace {

bool parse_finite(std::string_view token, double& out) {
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (first != last && *first == '+') ++first;
  const auto result = std::from_chars(first, last, out);
  return result.ec == std::errc() && result.ptr == last && std::isfinite(out);
}

/// The line as shown in a message: at most 60 characters, control characters replaced.
std::string shown(std::string_view line) {
  std::string s(line.substr(0, 60));
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  if (line.size() > 60) s += "...";
  return s;
}

/// Calls `per_line(text, number)` for each non-blank, non-comment line of the file.
template <class F>
void for_each_data_line(const std::string& path, F&& per_line) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path + ": cannot open");
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::string_view view(line);
    const auto first = view.find_first_not_of(" \t\r");
    if (first == std::string_view::npos || view[first] == '#') continue;
    per_line(view, number);
  }
  if (in.bad()) throw input_error(path + ": read error");
}

void write_header(std::FILE* file, const std::string& header) {
  if (header.empty()) return;
  std::istringstream lines(header);
  std::string line;
  while (std::getline(lines, line)) std::fprintf(file, "# %s\n", line.c_str());
}

/// printf of one %.9f field into `out`, with negative zero written as zero.
int put_fixed(char* out, std::size_t size, const char* format, double v) {
  int n = std::snprintf(out, size, format, v);
  if (n > 0 && out[0] == '-' && static_cast<std::size_t>(n) < size) {
    bool all_zero = true;
    for (int i = 1; i < n; ++i)
      if (out[i] != '0' && out[i] != '.') all_zero = false;
    if (all_zero) {
      std::memmove(out, out + 1, static_cast<std::size_t>(n));  // includes the terminator
      --n;
    }
  }
  return n;
}

}  // namespace

std::vector<TumListEntry> read_tum_list(const std::string& path) {
  std::vector<TumListEntry> entries;
  for_each_data_line(path, [&](std::string_view line, int number) {
    const auto tokens = split_tokens(line);
    TumListEntry entry;
    if (tokens.size() < 2 || !parse_finite(tokens[0], entry.timestamp_s))
      throw input_error(path + ":" + std::to_string(number) + ": expected 'timestamp path', got '" +
                        shown(line) + "'");
    entry.path = std::string(tokens[1]);
    entry.line = number;
    entries.push_back(std::move(entry));
  });
  return entries;
}

void write_tum_list(const std::string& path, const std::vector<TumListEntry>& entries,
                    const std::string& header) {
  write_atomically(path, [&](const std::string& partial) {
    std::FILE* file = std::fopen(partial.c_str(), "wb");
    if (!file) throw_write_failed(partial);
    write_header(file, header);
    for (const TumListEntry& e : entries)
      std::fprintf(file, "%.6f %s\n", e.timestamp_s, e.path.c_str());
    const bool failed = std::ferror(file) != 0;
    if (std::fclose(file) != 0 || failed) throw_write_failed(partial);
  });
}

std::vector<StampedPose> read_trajectory(const std::string& path) {
  std::vector<StampedPose> poses;
  for_each_data_line(path, [&](std::string_view line, int number) {
    const auto tokens = split_tokens(line);
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (tokens.size() != 8)
      throw input_error(where + "expected 'timestamp tx ty tz qx qy qz qw', got '" + shown(line) +
                        "'");
    double v[8];
    for (int i = 0; i < 8; ++i)
      if (!parse_finite(tokens[i], v[i]))
        throw input_error(where + "column " + std::to_string(i + 1) + " is not a finite number: '" +
                          shown(tokens[i]) + "'");
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (!(q.norm() > 1e-6)) throw input_error(where + "quaternion has zero length");
    poses.push_back({v[0], Pose::from_quaternion(Eigen::Vector3d(v[1], v[2], v[3]), q)});
  });
  return poses;
}

int format_trajectory_line(char* buffer, std::size_t size, const StampedPose& pose) {
  Eigen::Quaterniond q = pose.T_world_camera.quaternion();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d& t = pose.T_world_camera.translation();
  const double fields[7] = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
  int n = put_fixed(buffer, size, "%.6f", pose.timestamp_s);
  if (n < 0 || static_cast<std::size_t>(n) >= size) return -1;
  for (double f : fields) {
    if (static_cast<std::size_t>(n) + 2 >= size) return -1;
    buffer[n++] = ' ';
    const std::size_t remaining = size - static_cast<std::size_t>(n);
    const int m = put_fixed(buffer + n, remaining, "%.9f", f);
    if (m < 0 || static_cast<std::size_t>(m) >= remaining) return -1;
    n += m;
  }
  if (static_cast<std::size_t>(n) + 2 > size) return -1;
  buffer[n++] = '\n';
  buffer[n] = '\0';
  return n;
}

void write_trajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  write_atomically(path, [&poses](const std::string& partial) {
    TrajectoryWriter writer(partial);
    for (const StampedPose& p : poses) writer.write(p);
    writer.close();
  });
}

TrajectoryWriter::TrajectoryWriter(const std::string& path, const std::string& header)
    : path_(path), file_(std::fopen(path.c_str(), "wb")) {
  if (!file_) throw_write_failed(path_);
  write_header(file_, header);
  if (std::fflush(file_) != 0) throw_write_failed(path_);
}

TrajectoryWriter::~TrajectoryWriter() {
  if (file_) std::fclose(file_);
}

void TrajectoryWriter::write(const StampedPose& pose) {
  if (!file_) throw Error(ExitCode::kFailure, path_ + ": trajectory already closed");
  char line[512];
  const int n = format_trajectory_line(line, sizeof line, pose);
  if (n < 0) throw Error(ExitCode::kFailure, path_ + ": pose does not fit a trajectory line");
  if (std::fwrite(line, 1, static_cast<std::size_t>(n), file_) != static_cast<std::size_t>(n) ||
      std::fflush(file_) != 0)
    throw_write_failed(path_);
}

void TrajectoryWriter::close() {
  if (!file_) return;
  const bool failed = std::ferror(file_) != 0;
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0 || failed) throw_write_failed(path_);
}

std::optional<Pose> associate(const std::vector<StampedPose>& poses, double t_s, double max_dt_s) {
  const auto after =
      std::lower_bound(poses.begin(), poses.end(), t_s,
                       [](const StampedPose& p, double t) { return p.timestamp_s < t; });
  const StampedPose* best = nullptr;
  double best_dt = max_dt_s;
  if (after != poses.begin()) {  // the last pose before t (earlier wins ties)
    const StampedPose& before = *std::prev(after);
    if (t_s - before.timestamp_s <= best_dt) {
      best = &before;
      best_dt = t_s - before.timestamp_s;
    }
  }
  if (after != poses.end() && after->timestamp_s - t_s <= max_dt_s &&
      (!best || after->timestamp_s - t_s < best_dt))
    best = &*after;
  if (!best) return std::nullopt;
  return best->T_world_camera;
}

std::vector<std::optional<std::size_t>> associate_lists(const std::vector<TumListEntry>& first,
                                                        const std::vector<TumListEntry>& second,
                                                        double max_dt_s) {
  std::vector<std::size_t> by_time(second.size());
  for (std::size_t j = 0; j < by_time.size(); ++j) by_time[j] = j;
  std::stable_sort(by_time.begin(), by_time.end(), [&](std::size_t a, std::size_t b) {
    return second[a].timestamp_s < second[b].timestamp_s;
  });
  struct Pair {
    double dt;
    std::size_t i, j;
  };
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i < first.size(); ++i) {
    const double t = first[i].timestamp_s;
    auto k = std::lower_bound(by_time.begin(), by_time.end(), t - max_dt_s,
                              [&](std::size_t j, double v) { return second[j].timestamp_s < v; });
    for (; k != by_time.end() && second[*k].timestamp_s <= t + max_dt_s; ++k) {
      const double dt = std::abs(second[*k].timestamp_s - t);
      if (dt <= max_dt_s) pairs.push_back({dt, i, *k});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    if (a.dt != b.dt) return a.dt < b.dt;
    if (a.i != b.i) return a.i < b.i;
    return a.j < b.j;
  });
  std::vector<std::optional<std::size_t>> partner(first.size());
  std::vector<bool> taken(second.size(), false);
  for (const Pair& p : pairs) {
    if (partner[p.i] || taken[p.j]) continue;
    partner[p.i] = p.j;
    taken[p.j] = true;
  }
  return partner;
}

}  // namespace aoscan
