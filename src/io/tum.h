/// @file tum.h
/// @brief TUM RGB-D text files: file lists (depth.txt) and trajectories (groundtruth.txt,
/// trajectory.txt), plus nearest-timestamp association of poses to frames.
#pragma once

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "core/pose.h"

namespace aoscan {

/// One line `timestamp path` of a TUM file list.
struct TumListEntry {
  double timestamp_s = 0.0;  ///< seconds, as written
  std::string path;          ///< as written (TUM: relative to the list's folder)
  int line = 0;              ///< 1-based line number in the file, for messages
};

/// Reads a TUM file list: lines `timestamp path [more columns]`; `#` comments and blank lines are
/// skipped, extra columns ignored, CRLF accepted. An empty list is returned as is. Throws
/// input_error "FILE: cannot open" or "FILE:LINE: ..." for a line that is not `timestamp path`.
std::vector<TumListEntry> read_tum_list(const std::string& path);

/// Writes a TUM file list: `header` (each of its lines prefixed with "# ", omitted when empty),
/// then one `%.6f path` line per entry. Throws Error (exit code 1) when the file cannot be written.
void write_tum_list(const std::string& path, const std::vector<TumListEntry>& entries,
                    const std::string& header = "timestamp filename");

/// A pose with the timestamp (seconds) of the frame it belongs to.
struct StampedPose {
  double timestamp_s = 0.0;
  Pose T_world_camera;  ///< camera-to-world, metres
};

/// Reads a TUM trajectory: lines `timestamp tx ty tz qx qy qz qw` (camera-to-world, metres;
/// Hamilton quaternion, normalised on reading); `#` comments and blank lines skipped. Keeps the
/// file's order. Throws input_error "FILE: cannot open" or "FILE:LINE: ..." for a garbled line
/// (wrong column count, a non-number, a non-finite value, a zero quaternion).
std::vector<StampedPose> read_trajectory(const std::string& path);

/// Formats one trajectory line (with its '\n') into `buffer`; returns its length. The fixed format:
/// timestamp `%.6f`, then tx ty tz qx qy qz qw each `%.9f`, single spaces; the quaternion has
/// qw >= 0 and "-0.000000000" is written as "0.000000000", so output is byte-deterministic.
int format_trajectory_line(char* buffer, std::size_t size, const StampedPose& pose);

/// Writes a whole trajectory in format_trajectory_line's format (no header line). Throws Error
/// (exit code 1) when the file cannot be written.
void write_trajectory(const std::string& path, const std::vector<StampedPose>& poses);

/// Appends one trajectory line per frame to a file, as frames come (no allocation per line).
class TrajectoryWriter {
 public:
  /// Creates/truncates `path`; writes `header` as `# ` comment lines unless empty. Throws Error
  /// (exit code 1) when the file cannot be created.
  explicit TrajectoryWriter(const std::string& path, const std::string& header = "");
  ~TrajectoryWriter();
  TrajectoryWriter(const TrajectoryWriter&) = delete;
  TrajectoryWriter& operator=(const TrajectoryWriter&) = delete;

  /// Appends a line and flushes it to the OS, so the file is valid up to this pose at any time.
  /// Throws Error (exit code 1) on a write failure.
  void write(const StampedPose& pose);
  /// Closes the file; throws Error (exit code 1) when buffered data could not be written.
  void close();

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

/// The pose whose timestamp is nearest to `t_s` (seconds) when it is within `max_dt_s`, else
/// nullopt; on a tie the earlier pose wins. `poses` must be sorted by ascending timestamp.
std::optional<Pose> associate(const std::vector<StampedPose>& poses, double t_s, double max_dt_s);

/// The colour frames of a TUM recording are associated to its depth frames within this time
/// difference (seconds): the default of the TUM RGB-D benchmark's associate.py.
inline constexpr double kColourMaxDtS = 0.02;

/// Pairs the entries of two TUM lists as the TUM RGB-D benchmark's associate.py does: of all
/// pairs whose timestamps differ by at most `max_dt_s`, the closest pair first, each entry used
/// at most once (ties: the earlier entry of `first`, then of `second`). Returns, for each entry
/// of `first`, the index of its partner in `second`, or nullopt. The lists need not be sorted.
std::vector<std::optional<std::size_t>> associate_lists(const std::vector<TumListEntry>& first,
                                                        const std::vector<TumListEntry>& second,
                                                        double max_dt_s);

}  // namespace aoscan
