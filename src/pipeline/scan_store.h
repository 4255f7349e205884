/// @file scan_store.h
/// @brief The out-of-core side of `aoscan scans`: each scan's maps, SSAO and border distance in a
/// scratch file of its own, read back when the integration needs them, and a cache that holds as
/// many loaded scans as a memory budget allows.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <Eigen/Geometry>

#include "ao/multiscan.h"
#include "core/image.h"
#include "geometry/range_map.h"

namespace aoscan {

/// What the integration plans with, without a scan's maps: kept in memory for every scan.
struct ScanInfo {
  std::string name;
  std::string source;  ///< the file (and frame) it came from
  ScanCamera camera;
  Pose T_world_scanner;
  Eigen::AlignedBox3f world_box;  ///< of its points (scan_world_box())
  float max_depth_m = 0.0f;       ///< the largest depth of its points
  long long points = 0;
  long long skipped = 0;  ///< point-cloud points that did not fit the map
  ScanNoise noise;        ///< its map's range noise (RangeMap::noise)

  /// Pixels of its map.
  std::size_t pixels() const {
    return static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  }
  /// Bytes a loaded scan takes (ScanAo: points, normals, SSAO, border distance).
  std::size_t loaded_bytes() const { return pixels() * kLoadedBytesPerPixel; }
  static constexpr std::size_t kLoadedBytesPerPixel =
      2 * sizeof(Eigen::Vector3f) + 2 * sizeof(float);
};

/// The ScanInfo of a computed scan (box, largest depth, points and noise from its map).
ScanInfo describe_scan(const ScanAo& scan, std::string source, long long skipped);

/// Writes `scan` with its description to `path` (atomically): a header, then for every pixel with
/// a point its index, point, normal, SSAO and border distance (36 bytes a point, whatever the
/// map's size). Throws Error (exit code 1) naming the file when it cannot be written.
void write_scan_file(const std::string& path, const ScanInfo& info, const ScanAo& scan);

/// The description in the header of a scan file. Throws Error (exit code 1) naming the file when
/// it is missing, of another format or damaged.
ScanInfo read_scan_info(const std::string& path);

/// The whole scan of a scan file, its maps at full size. Throws as read_scan_info().
void read_scan_file(const std::string& path, ScanAo& scan);

/// Writes a scan's MVAO, one value per point of `map` (pixel order), and how many of its points
/// had a sample from another scan, to `path` (atomically).
void write_mvao_file(const std::string& path, const RangeMap& map, const Image<float>& mvao,
                     long long points_shared);

/// Reads what write_mvao_file() wrote into `mvao` (the map's size; 1 where there is no point) and
/// returns its points shared. Throws Error (exit code 1) naming the file when it is missing or
/// does not match `map`.
long long read_mvao_file(const std::string& path, const RangeMap& map, Image<float>& mvao);

/// The points shared of a complete MVAO file for a scan of `points` points; nothing when the file
/// is missing, damaged or of another size (a resumed run then integrates the scan again).
std::optional<long long> mvao_file_shared(const std::string& path, long long points);

/// Loaded scans, least recently used first out, within a byte budget.
class ScanCache {
 public:
  /// Scans are known by a key of the caller's choosing. The loader sets all of `scan`, which may
  /// hold a dropped scan of the same size (get()).
  using Loader = std::function<void(std::uint64_t key, ScanAo& scan)>;
  ScanCache(std::size_t budget_bytes, Loader load) : budget_(budget_bytes), load_(std::move(load)) {}

  /// Scan `key`, loaded (taking `bytes`) if it is not held. To make room the least recently
  /// used scans that nobody else holds are dropped; a scan still held elsewhere stays (the caller
  /// plans its budget so that what it holds at once fits). A dropped scan that this cache loaded
  /// and that takes as many bytes is loaded into (its images' storage reused: freshly mapped
  /// memory costs the kernel a page clearing per page, which a run reading scans back hundreds
  /// of times would pay each time).
  std::shared_ptr<const ScanAo> get(std::uint64_t key, std::size_t bytes);
  /// Keeps a scan computed elsewhere (as most recently used) if it fits the budget after dropping
  /// what can be dropped; otherwise drops it.
  void put(std::uint64_t key, std::shared_ptr<const ScanAo> scan, std::size_t bytes);
  /// Drops least recently used scans nobody else holds until at most `bytes` are held.
  void trim(std::size_t bytes) { trim(bytes, 0); }
  /// A new budget (what is held beyond it is dropped as far as it can be).
  void set_budget(std::size_t bytes) {
    budget_ = bytes;
    trim(budget_);
  }
  std::size_t budget() const { return budget_; }
  /// Scans read from their files so far.
  long long loads() const { return loads_; }
  /// Bytes held now.
  std::size_t held_bytes() const { return held_; }

 private:
  struct Entry {
    std::uint64_t key;
    std::size_t bytes;
    std::shared_ptr<ScanAo> scan;  ///< const but for a scan this cache loaded (`loaded`)
    bool loaded;
  };
  /// trim(), giving back one dropped scan that this cache loaded and that takes `reuse_bytes`
  /// (none when 0).
  std::shared_ptr<ScanAo> trim(std::size_t bytes, std::size_t reuse_bytes);
  std::size_t budget_;
  Loader load_;
  std::list<Entry> entries_;  ///< most recently used first
  std::size_t held_ = 0;
  long long loads_ = 0;
};

}  // namespace aoscan
