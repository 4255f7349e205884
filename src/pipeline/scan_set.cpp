/// @file scan_set.cpp
/// @brief `aoscan scans`: loading scan sets, per-scan SSAO, multi-view integration, outputs.
#include "pipeline/scan_set.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <set>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "ao/jump_flood.h"
#include "ao/multiscan.h"
#include "ao/scan_ssao.h"
#include "capture/png_depth.h"
#include "capture/tum_source.h"
#include "core/status.h"
#include "fusion/preprocess/preprocess.h"
#include "io/meshlab_project.h"
#include "io/ply.h"
#include "io/ptx.h"
#include "io/scan_manifest.h"
#include "io/atomic_write.h"
#include "io/tum.h"
#include "pipeline/output_folder.h"
#include "pipeline/ranks.h"
#include "pipeline/scan_mesh.h"
#include "pipeline/scan_store.h"
#include "pipeline/session.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// Poses of frames whose timestamps are within this of a trajectory's (the TUM tools' 20 ms).
constexpr double kPoseMatchS = 0.02;
/// border_distance(): a Laplacian edge must exceed this share of the pixel's depth.
constexpr float kMinEdgeRatio = 0.01f;

/// What a finished input unit holds: its scans (numbered on from the units before it) and the
/// frames it skipped; unit-N.json in the scratch folder.
struct UnitRecord {
  long long scans = 0;
  long long frames_without_pose = 0;
  long long frames_corrupt = 0;
};

void write_unit_record(const std::string& path, const UnitRecord& r) {
  const nlohmann::json j = {{"scans", r.scans},
                            {"frames_without_pose", r.frames_without_pose},
                            {"frames_corrupt", r.frames_corrupt}};
  write_atomically(path, [&j](const std::string& partial) {
    std::ofstream out(partial);
    out << j.dump() << "\n";
    if (!out.flush()) throw_write_failed(partial);
  });
}

/// False when the record is missing or unreadable (the unit is then read again).
bool read_unit_record(const std::string& path, UnitRecord& r) {
  std::ifstream in(path);
  if (!in) return false;
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object()) return false;
  try {
    r.scans = j.at("scans").get<long long>();
    r.frames_without_pose = j.at("frames_without_pose").get<long long>();
    r.frames_corrupt = j.at("frames_corrupt").get<long long>();
  } catch (const nlohmann::json::exception&) {
    return false;
  }
  return r.scans >= 0;
}

/// A pinhole range map of a raw depth frame: metres, range-clipped and border outliers removed
/// as the real-time path does.
void depth_scan(const DepthFrame& frame, const PreprocessConfig& preprocess, RangeMap& map) {
  Image<float> depth_m;
  preprocess_depth(frame, preprocess, depth_m);
  range_map_from_depth(depth_m, frame.intrinsics, map);
}

/// A scanner-frame point cloud (normals optional) as the equirectangular map of Sec. 7.
void cloud_scan(const std::vector<Eigen::Vector3f>& points,
                const std::vector<Eigen::Vector3f>& normals, RangeMap& map, ScanSummary& summary) {
  map.camera = ScanCamera::equirectangular_for_points(static_cast<long long>(points.size()));
  summary.skipped = rasterize_points(points, normals, map);
}

void load_manifest_scan(const ScanEntry& e, const Config& config, ScanAo& scan,
                        ScanSummary& summary) {
  RangeMap& map = scan.map;
  map.name = e.name;
  summary.source = e.path;
  if (e.kind == ScanEntry::Kind::kDepthImage) {
    DepthFrame frame;
    const Status status = read_depth_png(e.path, frame.depth);
    if (!status.is_ok()) throw input_error(status.message());
    frame.depth_scale = e.depth_scale;
    frame.intrinsics = e.intrinsics;
    frame.intrinsics.width = frame.depth.width();
    frame.intrinsics.height = frame.depth.height();
    frame.origin = e.path;
    depth_scan(frame, config.preprocess, map);
    map.T_world_scanner = e.T_world_scan;
    return;
  }
  const TriangleMesh cloud = read_ply(e.path);
  if (cloud.vertices.empty()) throw input_error(e.path + ": the point cloud is empty");
  std::vector<Eigen::Vector3f> points(cloud.vertices.size());
  const Eigen::Vector3f scanner = e.scanner.cast<float>();
  for (std::size_t i = 0; i < points.size(); ++i) points[i] = cloud.vertices[i] - scanner;
  cloud_scan(points, cloud.normals, map, summary);
  map.T_world_scanner = e.T_world_scan * Pose(Eigen::Matrix3d::Identity(), e.scanner);
}

/// A freshly loaded scan, handed to the first stage with where it came from.
using ScanSink = std::function<void(ScanAo& scan, ScanSummary& summary)>;

/// Every scan of a PTX file, one at a time, named by the file's stem, with its number when the
/// file holds more than one: a scan is handed on once the next one (or the end of the file) shows
/// which, so at most two are held at once.
void load_ptx(const std::string& path, const ScanSink& sink) {
  const std::string stem = fs::path(path).stem().string();
  // A scan is handed on when the next one (or the end of the file) shows whether the file holds
  // more than one, which its name depends on; so at most two scans are held at once.
  std::optional<PtxScan> pending;
  int number = 0;
  auto hand_on = [&](PtxScan& ptx, bool alone) {
    ++number;
    ScanAo scan;
    ScanSummary summary;
    scan.map.name = alone ? stem : stem + "-" + std::to_string(number);
    summary.source = path;
    if (ptx.points.empty())
      throw input_error(path + ": scan " + std::to_string(number) + " has no point");
    cloud_scan(ptx.points, {}, scan.map, summary);
    scan.map.T_world_scanner = ptx.T_world_scanner;
    ptx = PtxScan();
    sink(scan, summary);
  };
  read_ptx(path, [&](PtxScan&& ptx) {
    if (pending) hand_on(*pending, false);
    pending = std::move(ptx);
  });
  if (pending) hand_on(*pending, number == 0);
}

/// Every `every`-th frame of a recording folder, posed by `poses_path` or the folder's own
/// trajectory.
void load_recording(const std::string& folder, const ScansOptions& options, UnitRecord& unit,
                    const ScanSink& sink) {
  std::string poses_path = options.poses;
  if (poses_path.empty()) {
    for (const char* name : {"trajectory.txt", "groundtruth.txt"})
      if (fs::is_regular_file(fs::path(folder) / name)) {
        poses_path = (fs::path(folder) / name).string();
        break;
      }
    if (poses_path.empty())
      throw input_error(folder +
                        ": no trajectory.txt or groundtruth.txt to pose its frames "
                        "(give --poses FILE)");
  }
  const std::vector<StampedPose> poses = read_trajectory(poses_path);
  const std::unique_ptr<Source> source = open_tum_folder(folder);
  const std::string stem = fs::path(folder).lexically_normal().filename().string();
  DepthFrame frame;
  for (long long index = 0;; ++index) {
    const Status status = source->read(frame);
    if (status.code() == Status::Code::kEndOfStream) break;
    if (status.code() == Status::Code::kCorruptFrame) {
      spdlog::warn("skipping corrupt frame: {}", status.message());
      ++unit.frames_corrupt;
      continue;
    }
    if (!status.is_ok()) throw input_error(status.message());
    if (index % options.every != 0) continue;
    const std::optional<Pose> pose = associate(poses, frame.timestamp_s, kPoseMatchS);
    if (!pose) {
      ++unit.frames_without_pose;
      continue;
    }
    ScanAo scan;
    scan.map.name = stem + "-" + std::to_string(frame.sequence);
    depth_scan(frame, options.config.preprocess, scan.map);
    scan.map.T_world_scanner = *pose;
    ScanSummary summary;
    summary.source = frame.origin;
    sink(scan, summary);
  }
}

std::string extension(const std::string& path) { return fs::path(path).extension().string(); }

bool is_manifest(const std::string& path) {
  const std::string ext = extension(path);
  return ext == ".json" || ext == ".yaml" || ext == ".yml";
}

/// One input unit of the first stage: a manifest or MeshLab project entry (one scan), a PTX file
/// (its scans) or a recording folder (its every K-th frames). A finished unit is recorded in the
/// scratch folder, so that a resumed run skips it without reading it.
struct Unit {
  enum class Kind { kEntry, kPtx, kRecording };
  Kind kind = Kind::kEntry;
  ScanEntry entry;
  std::string path;  ///< the PTX file or recording folder (the entry's file for kEntry)
};

/// A scan's place among the inputs: its unit and its number there (known as it is read, before
/// the scans of earlier units are counted, so that ranks can name it independently).
struct ScanId {
  std::size_t unit = 0;
  long long k = 0;
  std::uint64_t key() const { return (static_cast<std::uint64_t>(unit) << 32) | static_cast<std::uint64_t>(k); }
};

/// The rank that computes scan k of unit u: each unit's scans dealt out in turn, each unit
/// starting one rank further, so that a manifest of one-scan entries spreads evenly too.
int owner(const ScanId& id, int ranks) {
  return static_cast<int>((id.unit + static_cast<std::uint64_t>(id.k)) % static_cast<std::uint64_t>(ranks));
}

/// The SSAO sample pattern of a scan: keyed by its name (unique in a set), so that a scan's SSAO
/// does not depend on where it stands among the inputs or on which rank computes it (FNV-1a).
std::uint64_t pattern_index(const std::string& name) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : name) h = (h ^ c) * 1099511628211ull;
  return h;
}

/// The units of the inputs, in order; manifests and projects are read (and checked) here.
std::vector<Unit> plan_units(const ScansOptions& options) {
  std::vector<Unit> units;
  for (const std::string& input : options.inputs) {
    if (is_manifest(input) || extension(input) == ".mlp") {
      const std::vector<ScanEntry> entries =
          is_manifest(input) ? read_scan_manifest(input) : read_meshlab_project(input);
      for (const ScanEntry& e : entries) units.push_back({Unit::Kind::kEntry, e, e.path});
    } else if (extension(input) == ".ptx") {
      units.push_back({Unit::Kind::kPtx, {}, input});
    } else if (fs::is_directory(input)) {
      units.push_back({Unit::Kind::kRecording, {}, input});
    } else if (!fs::exists(input)) {
      throw input_error(input + ": no such file or folder");
    } else {
      throw input_error(input + ": not a scan manifest (.json, .yaml), a MeshLab project (.mlp), "
                                "a PTX file (.ptx) or a recording folder");
    }
  }
  return units;
}

/// A file's identity for the resume check: its absolute path, size and modification time.
nlohmann::json file_identity(const std::string& path) {
  std::error_code ec;
  nlohmann::json j = {{"path", fs::absolute(path, ec).lexically_normal().string()}};
  const std::uintmax_t bytes = fs::file_size(path, ec);
  if (!ec) j["bytes"] = bytes;
  const auto mtime = fs::last_write_time(path, ec);
  if (!ec) j["mtime"] = mtime.time_since_epoch().count();
  return j;
}

/// Resident memory of the process now (bytes; 0 where /proc is missing).
std::uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t pages = 0, resident = 0;
  if (!(statm >> pages >> resident)) return 0;
  return resident * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
}

std::string mib(std::uint64_t bytes) {
  return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB";
}

/// Memory the first stage takes per pixel of a scan's map beyond the map itself: the SSAO and its
/// unsmoothed copy, and the border distance's depth, Laplacian, seeds and two jump-flooding
/// buffers (measured peak, rounded up; the normals' residuals and plane offsets, 4 bytes each
/// and gone before the border distance, stay under it).
constexpr std::uint64_t kStageOneBytesPerPixel = 72;
/// Held beside the budgeted scans: thread stacks, allocator slack, output buffers.
constexpr std::uint64_t kSlackBytes = 64ull << 20;

/// The memory limit less what the process held before the run and some slack: the bytes the
/// stages plan with.
class MemoryPlan {
 public:
  explicit MemoryPlan(std::uint64_t limit)
      : limit_(limit), resident_(resident_bytes()), base_(resident_ + kSlackBytes) {}
  std::uint64_t budget() const { return limit_ > base_ ? limit_ - base_ : 0; }
  /// What the process held before the run (bytes).
  std::uint64_t resident_before() const { return resident_; }
  /// Throws usage_error when `bytes` (for `what`) do not fit the budget.
  void require(std::uint64_t bytes, const std::string& what) const {
    if (bytes > budget())
      throw usage_error("--memory-limit " + mib(limit_) + " is too small for " + what +
                        ": give at least " + mib(base_ + bytes));
  }

 private:
  std::uint64_t limit_;
  std::uint64_t resident_;
  std::uint64_t base_;
};

/// The scratch folder: scan-U-K.bin (scan K of input unit U after the first stage), mvao-U-K.bin
/// (its MVAO), unit-U.json (a finished input unit) and run.json (what the files were computed
/// from).
class Scratch {
 public:
  Scratch(const ScansOptions& options, const std::vector<Unit>& units)
      : dir_(options.scratch_dir.empty() ? (fs::path(options.out_dir) / "scratch").string()
                                         : options.scratch_dir) {
    nlohmann::json inputs = nlohmann::json::array();
    for (const Unit& u : units) {
      nlohmann::json j = file_identity(u.path);
      if (u.kind == Unit::Kind::kEntry) {
        j["name"] = u.entry.name;
        j["scanner"] = {u.entry.scanner.x(), u.entry.scanner.y(), u.entry.scanner.z()};
        const Eigen::Matrix4d m = u.entry.T_world_scan.matrix();
        j["pose"] = std::vector<double>(m.data(), m.data() + 16);
        j["camera"] = {u.entry.intrinsics.fx, u.entry.intrinsics.fy, u.entry.intrinsics.cx,
                       u.entry.intrinsics.cy, u.entry.depth_scale};
      }
      if (u.kind == Unit::Kind::kRecording) {
        j["every"] = options.every;
        j["poses"] = options.poses.empty() ? nlohmann::json(nullptr) : file_identity(options.poses);
      }
      inputs.push_back(j);
    }
    // The format: of the scratch files and of what they mean (2: scans carry their range noise,
    // which the integration reads, and their border distance takes dropouts for no border).
    key_ = {{"format", 2},
            {"scans", {{"inputs", inputs}, {"config", dump_config(options.config)}}},
            {"integration", {{"neighbourhood", options.neighbourhood}}}};
  }

  const std::string& dir() const { return dir_; }
  std::string scan_file(const ScanId& id) const { return numbered("scan-", id, ".bin"); }
  std::string mvao_file(const ScanId& id) const { return numbered("mvao-", id, ".bin"); }
  std::string unit_file(std::size_t u) const {
    return (fs::path(dir_) / ("unit-" + digits(static_cast<long long>(u)) + ".json")).string();
  }

  /// Makes the folder ready. Resuming: checks that run.json describes these inputs and settings
  /// (usage_error naming what changed otherwise) and drops the MVAO files of another
  /// neighbourhood. Not resuming: removes what an earlier run left (with a warning).
  void open(bool resume) {
    require_writable_folder(dir_, "--scratch " + dir_);
    const fs::path run = fs::path(dir_) / "run.json";
    nlohmann::json earlier;
    if (fs::exists(run)) {
      std::ifstream in(run);
      earlier = nlohmann::json::parse(in, nullptr, false);
    }
    if (resume && earlier.is_object()) {
      if (earlier.value("format", 0) != key_["format"] || earlier["scans"] != key_["scans"]) {
        std::string what = "other inputs or settings";
        if (earlier.value("format", 0) == key_["format"] && earlier["scans"].is_object()) {
          const bool inputs = earlier["scans"]["inputs"] != key_["scans"]["inputs"];
          const bool config = earlier["scans"]["config"] != key_["scans"]["config"];
          if (inputs || config)
            what = inputs && config ? "other inputs and another configuration"
                   : inputs         ? "other inputs"
                                    : "another configuration";
        }
        throw usage_error("--resume: " + dir_ + " holds a run with " + what +
                          "; run without --resume to start over");
      }
      if (earlier["integration"] != key_["integration"]) {
        spdlog::info("--resume: the neighbourhood changed: integrating every scan again");
        remove_files("mvao-");
      }
    } else {
      if (resume) spdlog::warn("--resume: {} holds no earlier run: starting from the beginning", dir_);
      if (!resume && earlier.is_object())
        spdlog::warn("{} holds an unfinished earlier run: starting over (give --resume to continue "
                     "it)",
                     dir_);
      remove_files("");
    }
    write_atomically(run.string(), [this](const std::string& partial) {
      std::ofstream out(partial);
      out << key_.dump(2) << "\n";
      if (!out.flush()) throw_write_failed(partial);
    });
  }

  /// Removes the run's files and the folder when that leaves it empty.
  void remove() {
    remove_files("");
    std::error_code ec;
    fs::remove(dir_, ec);  // only when empty
  }

 private:
  static std::string digits(long long n) {
    char text[32];
    std::snprintf(text, sizeof text, "%06lld", n);
    return text;
  }
  std::string numbered(const char* prefix, const ScanId& id, const char* suffix) const {
    return (fs::path(dir_) / (prefix + digits(static_cast<long long>(id.unit)) + "-" +
                              digits(id.k) + suffix))
        .string();
  }
  /// Removes the scratch files whose names begin with `prefix` ("": every kind), nothing else.
  void remove_files(const std::string& prefix) {
    std::error_code ec;
    for (const fs::directory_entry& e : fs::directory_iterator(dir_, ec)) {
      const std::string name = e.path().filename().string();
      const bool ours = name == "run.json" || name.rfind("scan-", 0) == 0 ||
                        name.rfind("mvao-", 0) == 0 || name.rfind("unit-", 0) == 0;
      if (ours && name.rfind(prefix, 0) == 0 && e.is_regular_file(ec)) fs::remove(e.path(), ec);
    }
  }

  std::string dir_;
  nlohmann::json key_;
};

/// A progress line on stderr every few seconds during a long stage, with the time left.
class StageProgress {
 public:
  StageProgress(bool enabled, std::string stage, std::string unit, long long total)
      : enabled_(enabled), stage_(std::move(stage)), unit_(std::move(unit)), total_(total) {}
  void done(long long n) {
    done_ = n;
    if (!enabled_ || seconds_since(last_) < kEveryS) return;
    last_ = Clock::now();
    const double elapsed = seconds_since(start_);
    const double left = done_ > 0 ? elapsed * static_cast<double>(total_ - done_) / done_ : 0.0;
    std::fprintf(stderr, "aoscan: %s: %lld of %lld %s, %.0f s so far, about %.0f s left\n",
                 stage_.c_str(), done_, total_, unit_.c_str(), elapsed, left);
  }

 private:
  static constexpr double kEveryS = 5.0;
  bool enabled_;
  std::string stage_, unit_;
  long long total_;
  long long done_ = 0;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_ = Clock::now();
};

/// The points of scan `s` in the world frame with `ao` as their quality.
TriangleMesh world_points(const ScanAo& s, const Image<float>& ao, long long points) {
  TriangleMesh out;
  out.vertices.reserve(static_cast<std::size_t>(points));
  out.normals.reserve(static_cast<std::size_t>(points));
  out.quality.reserve(static_cast<std::size_t>(points));
  const RangeMap& map = s.map;
  const Eigen::Matrix3f R = map.T_world_scanner.rotation().cast<float>();
  const Eigen::Vector3f t = map.T_world_scanner.translation().cast<float>();
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      if (!map.has_point(x, y)) continue;
      out.vertices.push_back(R * map.points(x, y) + t);
      out.normals.push_back(R * map.normals(x, y));
      out.quality.push_back(ao(x, y));
    }
  return out;
}

/// points.ply: the vertices of every scans/<name>.ply, in scan order, under one header.
void join_scan_files(const std::string& path, const std::vector<std::string>& files,
                     const std::vector<long long>& counts) {
  long long total = 0;
  for (long long n : counts) total += n;
  std::ofstream out(path, std::ios::binary);
  const std::string header = ply_header(static_cast<std::size_t>(total), 0);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  std::vector<char> buffer(1 << 20);
  for (std::size_t i = 0; i < files.size(); ++i) {
    std::ifstream in(files[i], std::ios::binary);
    in.seekg(static_cast<std::streamoff>(ply_header(static_cast<std::size_t>(counts[i]), 0).size()));
    std::uint64_t left = static_cast<std::uint64_t>(counts[i]) * kPlyVertexBytes;
    while (left > 0 && in) {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, buffer.size()));
      in.read(buffer.data(), static_cast<std::streamsize>(n));
      out.write(buffer.data(), in.gcount());
      left -= static_cast<std::uint64_t>(in.gcount());
    }
    if (left != 0 || in.peek() != std::char_traits<char>::eof())
      throw Error(ExitCode::kFailure, files[i] + ": changed while points.ply was being written");
  }
  if (!out.flush()) throw_write_failed(path);
}

void write_stats(const std::string& path, const ScansResult& r, const ScansOptions& options,
                 const OutputFolder& folder, const std::string& scratch, int ranks) {
  nlohmann::json j;
  j["status"] = r.interrupted               ? "interrupted"
                : r.failed_outputs.empty() ? "complete"
                                           : "failed";
  j["scans"] = r.scans.size();
  j["points"] = r.points;
  j["wall_s"] = r.wall_s;
  j["peak_rss_mb"] = peak_rss_mb();
  j["ranks"] = ranks;
  j["memory_limit_mb"] = static_cast<double>(options.memory_limit) / (1 << 20);
  j["memory_before_mb"] = r.memory_before_mb;
  j["neighbourhood"] = options.neighbourhood;
  j["quality"] = options.ssao_only ? "ssao" : "mvao";
  j["frames_without_pose"] = r.frames_without_pose;
  j["frames_corrupt"] = r.frames_corrupt;
  j["pairs_tested"] = r.pairs_tested;
  j["pairs_skipped"] = r.pairs_skipped;
  j["points_shared"] = r.points_shared;
  j["isolated_scans"] = r.isolated_scans;
  j["d_max_m"] = r.d_max_m;
  j["scans_resumed"] = r.scans_resumed;
  j["integrations_resumed"] = r.integrations_resumed;
  j["scan_loads"] = r.scan_loads;
  j["scratch"] = scratch;
  j["stages_s"] = {
      {"load", r.load_s}, {"ssao", r.ssao_s}, {"integrate", r.integrate_s}, {"write", r.write_s}};
  if (options.mesh)
    j["mesh"] = {{"vertices", r.mesh_vertices},
                 {"faces", r.mesh_faces},
                 {"vertices_without_ao", r.mesh_vertices_without_ao},
                 {"tsdf_blocks", r.mesh_tsdf_blocks},
                 {"capacity_reached", r.mesh_capacity_reached},
                 {"seconds", r.mesh_s}};
  nlohmann::json per_scan = nlohmann::json::array();
  for (const ScanSummary& s : r.scans)
    per_scan.push_back({{"name", s.name},
                        {"source", s.source},
                        {"width", s.width},
                        {"height", s.height},
                        {"points", s.points},
                        {"points_skipped", s.skipped}});
  j["per_scan"] = per_scan;
  j["files"] = folder.files_json();
  j["failed_outputs"] = folder.failures_json();
  write_atomically(path, [&j](const std::string& partial) {
    std::ofstream out(partial);
    out << j.dump(2) << "\n";
    if (!out.flush()) throw_write_failed(partial);
  });
}

/// Thrown at a scan boundary of the SSAO and MVAO stages once a stop is requested.
struct ScansStopped {};

void check_stop(const ScansOptions& options) {
  if (options.stop != nullptr && options.stop->load()) throw ScansStopped{};
}

/// The first stage, this rank's share: every unit's scans loaded, their normals, SSAO and border
/// distances computed and written to the scratch folder, one scan in memory at a time. A unit of
/// one scan is read only by the rank that computes it; a PTX file or a recording by every rank
/// with a scan in it. The rank of the unit's first scan writes the unit's record.
void first_stage(const ScansOptions& options, const std::vector<Unit>& units,
                 const Scratch& scratch, const MemoryPlan& plan, ScanCache& cache, Ranks& ranks,
                 ScansResult& result) {
  const Clock::time_point start = Clock::now();
  double compute_s = 0.0;
  std::set<std::string> names;  // this rank's: gather_scans() checks them all
  std::uint64_t largest_need = 0;
  StageProgress progress(options.show_progress && ranks.rank() == 0, "SSAO", "inputs",
                         static_cast<long long>(units.size()));
  for (std::size_t u = 0; u < units.size(); ++u) {
    const Unit& unit = units[u];
    if (unit.kind == Unit::Kind::kEntry && owner({u, 0}, ranks.size()) != ranks.rank()) continue;
    UnitRecord record;
    if (options.resume && read_unit_record(scratch.unit_file(u), record)) {
      long long mine = 0;
      try {
        for (long long k = 0; k < record.scans; ++k)
          if (owner({u, k}, ranks.size()) == ranks.rank()) {
            names.insert(read_scan_info(scratch.scan_file({u, k})).name);
            ++mine;
          }
        result.scans_resumed += mine;
        progress.done(static_cast<long long>(u + 1));
        continue;
      } catch (const Error& e) {
        spdlog::warn("--resume: {}: reading the input again", one_line(e.what()));
      }
      record = UnitRecord();
    }
    // Room for reading the unit's next scan as for the largest one so far (its own need is known
    // only once it is read; the scans of a set are mostly alike).
    cache.trim(plan.budget() - std::min(plan.budget(), largest_need));
    const ScanSink sink = [&](ScanAo& scan, ScanSummary& summary) {
      const ScanId id{u, record.scans++};
      if (owner(id, ranks.size()) != ranks.rank()) return;
      check_stop(options);
      if (!names.insert(scan.map.name).second)
        throw input_error(summary.source + ": a second scan named " + scan.map.name);
      const std::string file = scratch.scan_file(id);
      if (options.resume && fs::exists(file)) {
        try {
          const ScanInfo info = read_scan_info(file);
          if (info.name == scan.map.name && info.source == summary.source) {
            ++result.scans_resumed;
            return;
          }
        } catch (const Error& e) {
          spdlog::warn("--resume: {}: computing the scan again", one_line(e.what()));
        }
      }
      if (scan.map.count_points() == 0)
        throw input_error(summary.source + ": scan " + scan.map.name + " has no valid point");
      const std::uint64_t need = static_cast<std::uint64_t>(scan.map.points.size()) *
                                 (ScanInfo::kLoadedBytesPerPixel + kStageOneBytesPerPixel);
      plan.require(need, "scan " + scan.map.name + " (a " + std::to_string(scan.map.camera.width) +
                             " x " + std::to_string(scan.map.camera.height) + " map)");
      cache.trim(plan.budget() - need);
      largest_need = std::max(largest_need, need);
      const Clock::time_point compute_start = Clock::now();
      RangeMap& map = scan.map;
      {
        const Image<float> plane_offset_m = compute_scan_normals(map);
        compute_scan_ssao(map, options.config.ao, pattern_index(map.name), scan.ssao,
                          plane_offset_m);
      }  // the offsets go before the border distance's buffers come
      border_distance(map, kMinEdgeRatio, scan.border_px);
      const ScanInfo info = describe_scan(scan, summary.source, summary.skipped);
      write_scan_file(file, info, scan);
      compute_s += seconds_since(compute_start);
      cache.put(id.key(), std::make_shared<const ScanAo>(std::move(scan)), info.loaded_bytes());
    };
    switch (unit.kind) {
      case Unit::Kind::kEntry: {
        ScanAo scan;
        ScanSummary summary;
        load_manifest_scan(unit.entry, options.config, scan, summary);
        sink(scan, summary);
        break;
      }
      case Unit::Kind::kPtx:
        load_ptx(unit.path, sink);
        break;
      case Unit::Kind::kRecording:
        load_recording(unit.path, options, record, sink);
        break;
    }
    if (owner({u, 0}, ranks.size()) == ranks.rank())  // one writer (each rank has read it)
      write_unit_record(scratch.unit_file(u), record);
    progress.done(static_cast<long long>(u + 1));
  }
  result.ssao_s = compute_s;
  result.load_s = seconds_since(start) - compute_s;
}

/// After every rank's first stage: all the scans, in the order of the inputs, from the units'
/// records and the scans' files; the frames the units skipped. Throws input_error on two scans of
/// one name or a set without a scan.
void gather_scans(const std::vector<Unit>& units, const Scratch& scratch, std::vector<ScanId>& ids,
                  std::vector<ScanInfo>& infos, ScansResult& result) {
  std::set<std::string> names;
  for (std::size_t u = 0; u < units.size(); ++u) {
    UnitRecord record;
    if (!read_unit_record(scratch.unit_file(u), record))
      throw Error(ExitCode::kFailure, scratch.unit_file(u) + ": missing after the first stage");
    result.frames_without_pose += record.frames_without_pose;
    result.frames_corrupt += record.frames_corrupt;
    for (long long k = 0; k < record.scans; ++k) {
      ScanInfo info = read_scan_info(scratch.scan_file({u, k}));
      if (!names.insert(info.name).second)
        throw input_error(info.source + ": a second scan named " + info.name);
      ids.push_back({u, k});
      infos.push_back(std::move(info));
    }
  }
  if (infos.empty()) throw input_error("scans: the inputs hold no scan");
}

/// The second stage: each scan's MVAO from the scans whose boxes meet its own, read back from
/// the scratch folder within the memory budget; written there as mvao-N.bin.
void second_stage(const ScansOptions& options, const std::vector<ScanId>& ids,
                  const std::vector<ScanInfo>& infos, const Scratch& scratch,
                  const MemoryPlan& plan, ScanCache& cache, Ranks& ranks, ScansResult& result) {
  MultiScanParams params;
  params.d_min_m = static_cast<float>(options.config.ao.d_min_m);
  params.d_max_m = std::max(static_cast<float>(result.d_max_m), params.d_min_m + 1e-3f);
  params.neighbourhood = options.neighbourhood;
  const int n = static_cast<int>(infos.size());

  // The accumulator of the largest scan, one MVAO image, and the two largest scans at once must
  // fit; the rest of the budget holds more scans being integrated and loaded scans.
  std::size_t largest = 0, second = 0, largest_pixels = 0;
  std::string largest_name;
  for (const ScanInfo& info : infos) {
    const std::size_t b = info.loaded_bytes();
    if (b > largest) {
      second = largest;
      largest = b;
      largest_name = info.name;
    } else {
      second = std::max(second, b);
    }
    largest_pixels = std::max(largest_pixels, info.pixels());
  }
  const std::uint64_t accumulator_bytes_per_pixel = MvaoAccumulator::kBytesPerPixel;
  // The samples of the scan being added (their storage kept), and one MVAO image at a time.
  const std::uint64_t finish_bytes = largest_pixels * (sizeof(float) + MvaoSamples::kBytesPerPixel);
  plan.require(largest_pixels * accumulator_bytes_per_pixel + finish_bytes + largest + second,
               "integrating scan " + largest_name + " with another");

  // Which scans each scan takes samples from: itself and those whose boxes meet its own.
  std::vector<std::vector<int>> candidates(n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      if (j != i && !scan_boxes_meet(infos[i].world_box, infos[j].world_box,
                                     pair_margin(params, infos[i].noise, infos[j].noise))) {
        ++result.pairs_skipped;
        continue;
      }
      if (j != i) ++result.pairs_tested;
      candidates[i].push_back(j);
    }
  // This rank's scans still to integrate.
  std::vector<int> mine;
  for (int i = ranks.rank(); i < n; i += ranks.size()) {
    if (options.resume && mvao_file_shared(scratch.mvao_file(ids[i]), infos[i].points))
      ++result.integrations_resumed;
    else
      mine.push_back(i);
  }

  // Batches of scans integrated together: each batch's scans and accumulators stay in memory
  // while every scan any of them needs is read once, in index order (so each accumulator adds its
  // candidates in the same order as alone, and gives the same bytes).
  StageProgress progress(options.show_progress && ranks.rank() == 0, "MVAO", "scans",
                         static_cast<long long>(mine.size()));
  std::size_t next = 0;
  MvaoSamples samples_j;  // of the scan being added, its storage reused
  while (next < mine.size()) {
    std::vector<int> batch;
    std::uint64_t used = finish_bytes + largest;  // and one more scan streaming through
    for (; next < mine.size(); ++next) {
      const ScanInfo& info = infos[mine[next]];
      const std::uint64_t need = info.loaded_bytes() + info.pixels() * accumulator_bytes_per_pixel;
      if (!batch.empty() && used + need > plan.budget()) break;
      batch.push_back(mine[next]);
      used += need;
    }
    std::uint64_t accumulators = 0;
    for (int i : batch) accumulators += infos[i].pixels() * accumulator_bytes_per_pixel;
    cache.set_budget(plan.budget() - accumulators - finish_bytes);
    std::vector<std::shared_ptr<const ScanAo>> held;
    std::vector<std::unique_ptr<MvaoAccumulator>> sums;
    for (int i : batch) {
      held.push_back(cache.get(ids[i].key(), infos[i].loaded_bytes()));
      sums.push_back(std::make_unique<MvaoAccumulator>(*held.back(), params));
    }
    std::vector<int> needed;
    for (int i : batch) needed.insert(needed.end(), candidates[i].begin(), candidates[i].end());
    std::sort(needed.begin(), needed.end());
    needed.erase(std::unique(needed.begin(), needed.end()), needed.end());
    for (int j : needed) {
      check_stop(options);
      const std::shared_ptr<const ScanAo> scan_j = cache.get(ids[j].key(), infos[j].loaded_bytes());
      samples_j.make(*scan_j, params);
      for (std::size_t b = 0; b < batch.size(); ++b)
        if (std::binary_search(candidates[batch[b]].begin(), candidates[batch[b]].end(), j))
          sums[b]->add(*scan_j, samples_j, j == batch[b]);
    }
    for (std::size_t b = 0; b < batch.size(); ++b) {
      Image<float> mvao;
      const long long shared = sums[b]->finish(mvao);
      write_mvao_file(scratch.mvao_file(ids[batch[b]]), held[b]->map, mvao, shared);
      sums[b].reset();
    }
    progress.done(static_cast<long long>(next));
  }
  result.scan_loads = cache.loads();
  ranks.barrier();
  // Every rank's MVAO files are complete: how many points each scan shares.
  for (int i = 0; i < n; ++i) {
    const std::optional<long long> shared = mvao_file_shared(scratch.mvao_file(ids[i]), infos[i].points);
    if (!shared)
      throw Error(ExitCode::kFailure, scratch.mvao_file(ids[i]) + ": missing or damaged after the integration");
    result.points_shared += *shared;
    if (*shared == 0 && n > 1) result.isolated_scans.push_back(infos[i].name);
  }
}

/// The outputs: scans/<name>.ply from each scan's scratch files, then points.ply joining them.
void write_outputs(const ScansOptions& options, const std::vector<ScanId>& ids,
                   const std::vector<ScanInfo>& infos, const Scratch& scratch, ScanCache& cache,
                   OutputFolder& folder) {
  std::error_code ec;
  fs::create_directories(fs::path(folder.dir()) / "scans", ec);
  std::vector<std::string> files;
  std::vector<long long> counts;
  std::string missing;
  StageProgress progress(options.show_progress, "writing", "scans", static_cast<long long>(infos.size()));
  for (std::size_t i = 0; i < infos.size(); ++i) {
    const std::string name = "scans/" + infos[i].name + ".ply";
    const bool ok = folder.write(name, [&](const std::string& path) {
      const std::shared_ptr<const ScanAo> scan = cache.get(ids[i].key(), infos[i].loaded_bytes());
      Image<float> mvao;
      if (!options.ssao_only) read_mvao_file(scratch.mvao_file(ids[i]), scan->map, mvao);
      write_ply(path, world_points(*scan, options.ssao_only ? scan->ssao : mvao, infos[i].points));
    });
    if (!ok && missing.empty()) missing = name;
    files.push_back(folder.path(name));
    counts.push_back(infos[i].points);
    progress.done(static_cast<long long>(i + 1));
  }
  folder.write("points.ply", [&](const std::string& path) {
    if (!missing.empty())
      throw Error(ExitCode::kFailure, path + ": not written: it joins the scans' files, and " +
                                          missing + " could not be written");
    write_atomically(path, [&](const std::string& partial) { join_scan_files(partial, files, counts); });
  });
}

/// --mesh: mesh.ply from the scans, each vertex with the AO its points were given.
void write_mesh(const ScansOptions& options, const std::vector<ScanId>& ids,
                const std::vector<ScanInfo>& infos, const Scratch& scratch, ScanCache& cache,
                OutputFolder& folder, ScansResult& result) {
  const Clock::time_point start = Clock::now();
  ScanMeshStats stats;
  const TriangleMesh mesh = mesh_scans(
      static_cast<int>(infos.size()),
      [&](int i) { return cache.get(ids[i].key(), infos[i].loaded_bytes()); },
      [&](int i, const ScanAo& scan, Image<float>& ao) {
        if (options.ssao_only)
          ao = scan.ssao;
        else
          read_mvao_file(scratch.mvao_file(ids[i]), scan.map, ao);
      },
      options.config.fusion, stats);
  if (stats.capacity_reached)
    spdlog::warn("mesh.ply: the TSDF reached tsdf.max_blocks ({}): parts of the scans are missing "
                 "from it (raise tsdf.max_blocks or tsdf.voxel_size_m)",
                 options.config.fusion.max_blocks);
  if (stats.vertices_without_ao > 0)
    spdlog::warn("mesh.ply: {} of {} vertices have no scan point within {} m: their AO is 1",
                 stats.vertices_without_ao, stats.vertices, options.config.fusion.truncation_m);
  folder.write("mesh.ply", [&mesh](const std::string& path) { write_ply(path, mesh); });
  result.mesh_vertices = stats.vertices;
  result.mesh_faces = stats.faces;
  result.mesh_vertices_without_ao = stats.vertices_without_ao;
  result.mesh_tsdf_blocks = stats.tsdf_blocks;
  result.mesh_capacity_reached = stats.capacity_reached;
  result.mesh_s = seconds_since(start);
}

/// After a stop in the SSAO or MVAO stage: stats.json says "interrupted" (no other output is
/// written) and the scratch folder stays for --resume; several ranks are aborted (the others may
/// be waiting for this one).
ScansResult stopped(const ScansOptions& options, OutputFolder& folder, const Scratch& scratch,
                    Ranks& ranks, Clock::time_point start, ScansResult& result) {
  if (ranks.size() > 1) {
    std::fprintf(stderr,
                 "aoscan: error: stopped by a signal (rank %d of %d); the scratch folder %s keeps "
                 "the finished scans for --resume\n",
                 ranks.rank(), ranks.size(), scratch.dir().c_str());
    ranks.abort(static_cast<int>(ExitCode::kFailure));
  }
  result.interrupted = true;
  result.wall_s = seconds_since(start);
  folder.write("stats.json", [&](const std::string& path) {
    write_stats(path, result, options, folder, scratch.dir(), ranks.size());
  });
  return result;
}

}  // namespace

ScansResult run_scans(const ScansOptions& options) { return run_scans(options, *single_process()); }

ScansResult run_scans(const ScansOptions& options, Ranks& ranks) {
  const Clock::time_point start = Clock::now();
  if (options.inputs.empty()) throw usage_error("scans: give at least one INPUT");
  if (options.every < 1) throw usage_error("scans: --every must be at least 1");
  const bool lead = ranks.rank() == 0;
  ScansResult result;
  // Inputs and the scratch folder first: a refused --resume leaves the earlier outputs in place.
  const std::vector<Unit> units = plan_units(options);
  Scratch scratch(options, units);
  OutputFolder folder(options.out_dir, nullptr);
  if (lead) {
    scratch.open(options.resume);
    std::vector<std::string> writes = {"points.ply", "stats.json"};
    if (options.mesh) writes.push_back("mesh.ply");
    folder.prepare({"points.ply", "stats.json", "scans/", "mesh.ply"}, writes);
  }
  ranks.barrier();

  const MemoryPlan plan(options.memory_limit);
  result.memory_before_mb = static_cast<double>(plan.resident_before()) / (1 << 20);
  ScanCache cache(plan.budget(), [&scratch](std::uint64_t key, ScanAo& scan) {
    read_scan_file(scratch.scan_file({static_cast<std::size_t>(key >> 32),
                                      static_cast<long long>(key & 0xffffffffu)}),
                   scan);
  });
  try {
    first_stage(options, units, scratch, plan, cache, ranks, result);
  } catch (const ScansStopped&) {
    return stopped(options, folder, scratch, ranks, start, result);
  }
  ranks.barrier();
  std::vector<ScanId> ids;
  std::vector<ScanInfo> infos;
  gather_scans(units, scratch, ids, infos, result);
  for (const ScanInfo& info : infos) {
    ScanSummary s;
    s.name = info.name;
    s.source = info.source;
    s.width = info.camera.width;
    s.height = info.camera.height;
    s.points = info.points;
    s.skipped = info.skipped;
    result.scans.push_back(s);
    result.points += info.points;
    result.d_max_m = std::max(result.d_max_m, static_cast<double>(info.max_depth_m));
  }

  const Clock::time_point integrate_start = Clock::now();
  try {
    if (!options.ssao_only) second_stage(options, ids, infos, scratch, plan, cache, ranks, result);
  } catch (const ScansStopped&) {
    return stopped(options, folder, scratch, ranks, start, result);
  }
  result.integrate_s = seconds_since(integrate_start);
  result.scans_resumed = ranks.sum(result.scans_resumed);
  result.integrations_resumed = ranks.sum(result.integrations_resumed);
  result.scan_loads = ranks.sum(result.scan_loads);
  if (!lead) return result;  // the outputs are the first rank's

  const Clock::time_point write_start = Clock::now();
  write_outputs(options, ids, infos, scratch, cache, folder);
  if (options.mesh) write_mesh(options, ids, infos, scratch, cache, folder, result);
  for (const std::string& name : result.isolated_scans)
    spdlog::warn("scan {} overlaps no other scan: its points keep their own SSAO", name);
  result.write_s = seconds_since(write_start);
  result.wall_s = seconds_since(start);
  const nlohmann::json failures = folder.failures_json();
  for (const auto& [name, error] : failures.items())
    result.failed_outputs.emplace_back(name, error.get<std::string>());
  folder.write("stats.json", [&](const std::string& path) {
    write_stats(path, result, options, folder, scratch.dir(), ranks.size());
  });
  const nlohmann::json after = folder.failures_json();
  if (after.contains("stats.json"))
    result.failed_outputs.emplace_back("stats.json", after["stats.json"].get<std::string>());
  if (result.failed_outputs.empty() && !options.keep_scratch) scratch.remove();
  return result;
}

}  // namespace aoscan
