/// @file scan_store.cpp
/// @brief Scratch files of scans and their MVAO; the budgeted scan cache.
#include "pipeline/scan_store.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/status.h"
#include "io/atomic_write.h"

namespace aoscan {
namespace {

constexpr char kScanMagic[] = "AOSCAN-SCAN 2\n";
constexpr char kValuesMagic[] = "AOSCAN-VALS 1\n";
constexpr std::size_t kMagicSize = sizeof(kScanMagic) - 1;
static_assert(sizeof(kValuesMagic) - 1 == kMagicSize);

/// One point of a scan file.
struct PointRecord {
  std::uint32_t pixel;
  float point[3];
  float normal[3];
  float ssao;
  float border_px;
};
static_assert(sizeof(PointRecord) == 36);

/// Buffered binary output to a file; ok() false after any failed write.
class BinaryOut {
 public:
  explicit BinaryOut(const std::string& path) : path_(path), file_(std::fopen(path.c_str(), "wb")) {
    if (!file_) throw_write_failed(path);
    buffer_.reserve(kChunk);
  }
  ~BinaryOut() {
    if (file_) std::fclose(file_);
  }
  template <typename T>
  void put(const T& v) {
    bytes(&v, sizeof v);
  }
  void bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    buffer_.insert(buffer_.end(), p, p + n);
    if (buffer_.size() >= kChunk) flush();
  }
  void string(const std::string& s) {
    put(static_cast<std::uint32_t>(s.size()));
    bytes(s.data(), s.size());
  }
  void close() {
    flush();
    const bool ok = ok_ && std::ferror(file_) == 0;
    const bool closed = std::fclose(file_) == 0;
    file_ = nullptr;
    if (!ok || !closed) throw_write_failed(path_);
  }

 private:
  void flush() {
    if (ok_ && !buffer_.empty())
      ok_ = std::fwrite(buffer_.data(), 1, buffer_.size(), file_) == buffer_.size();
    buffer_.clear();
  }
  static constexpr std::size_t kChunk = 1 << 20;
  std::string path_;
  std::FILE* file_;
  std::vector<unsigned char> buffer_;
  bool ok_ = true;
};

/// Binary input that names the file in every error.
class BinaryIn {
 public:
  explicit BinaryIn(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    if (!in_) fail("cannot open it");
  }
  template <typename T>
  T get() {
    T v;
    bytes(&v, sizeof v);
    return v;
  }
  void bytes(void* data, std::size_t n) {
    if (!in_.read(static_cast<char*>(data), static_cast<std::streamsize>(n)))
      fail("it ends early");
  }
  std::string string() {
    const std::uint32_t n = get<std::uint32_t>();
    if (n > 1u << 20) fail("a name is " + std::to_string(n) + " bytes long");
    std::string s(n, '\0');
    bytes(s.data(), n);
    return s;
  }
  void magic(const char* expected) {
    char m[kMagicSize];
    bytes(m, kMagicSize);
    if (std::memcmp(m, expected, kMagicSize) != 0) fail("it is not a scratch file of this version");
  }
  /// Bytes read so far.
  std::uint64_t position() { return static_cast<std::uint64_t>(in_.tellg()); }
  void expect_end() {
    if (in_.peek() != std::char_traits<char>::eof()) fail("it is longer than its header says");
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw Error(ExitCode::kFailure, path_ + ": damaged scratch file: " + why);
  }

 private:
  std::string path_;
  std::ifstream in_;
};

void put_info(BinaryOut& out, const ScanInfo& info) {
  out.string(info.name);
  out.string(info.source);
  out.put(static_cast<std::int32_t>(info.camera.projection));
  out.put(static_cast<std::int32_t>(info.camera.width));
  out.put(static_cast<std::int32_t>(info.camera.height));
  const Intrinsics& k = info.camera.pinhole;
  out.put(static_cast<std::int32_t>(k.width));
  out.put(static_cast<std::int32_t>(k.height));
  for (double v : {k.fx, k.fy, k.cx, k.cy}) out.put(v);
  const Eigen::Matrix4d m = info.T_world_scanner.matrix();
  out.bytes(m.data(), sizeof(double) * 16);
  out.bytes(info.world_box.min().data(), sizeof(float) * 3);
  out.bytes(info.world_box.max().data(), sizeof(float) * 3);
  out.put(info.max_depth_m);
  out.put(static_cast<std::int64_t>(info.points));
  out.put(static_cast<std::int64_t>(info.skipped));
  out.put(info.noise.log_lo);
  out.put(info.noise.bin_per_log);
  out.bytes(info.noise.sigma_m.data(), sizeof(float) * ScanNoise::kBins);
}

ScanInfo get_info(BinaryIn& in) {
  ScanInfo info;
  in.magic(kScanMagic);
  info.name = in.string();
  info.source = in.string();
  const auto projection = in.get<std::int32_t>();
  if (projection != static_cast<std::int32_t>(ScanProjection::kPinhole) &&
      projection != static_cast<std::int32_t>(ScanProjection::kEquirectangular))
    in.fail("unknown projection");
  info.camera.projection = static_cast<ScanProjection>(projection);
  info.camera.width = in.get<std::int32_t>();
  info.camera.height = in.get<std::int32_t>();
  Intrinsics& k = info.camera.pinhole;
  k.width = in.get<std::int32_t>();
  k.height = in.get<std::int32_t>();
  for (double* v : {&k.fx, &k.fy, &k.cx, &k.cy}) *v = in.get<double>();
  if (!info.camera.valid()) in.fail("its camera is not valid");
  Eigen::Matrix4d m;
  in.bytes(m.data(), sizeof(double) * 16);
  info.T_world_scanner = Pose::from_matrix(m);
  in.bytes(info.world_box.min().data(), sizeof(float) * 3);
  in.bytes(info.world_box.max().data(), sizeof(float) * 3);
  info.max_depth_m = in.get<float>();
  info.points = in.get<std::int64_t>();
  info.skipped = in.get<std::int64_t>();
  info.noise.log_lo = in.get<float>();
  info.noise.bin_per_log = in.get<float>();
  in.bytes(info.noise.sigma_m.data(), sizeof(float) * ScanNoise::kBins);
  if (!std::isfinite(info.noise.log_lo) || !(info.noise.bin_per_log >= 0.0f) ||
      !std::isfinite(info.noise.bin_per_log) ||
      !std::all_of(info.noise.sigma_m.begin(), info.noise.sigma_m.end(),
                   [](float v) { return v >= 0.0f && std::isfinite(v); }))
    in.fail("its noise table is damaged");
  if (info.points < 0 || static_cast<std::size_t>(info.points) > info.pixels())
    in.fail("its point count does not fit its map");
  return info;
}

}  // namespace

ScanInfo describe_scan(const ScanAo& scan, std::string source, long long skipped) {
  ScanInfo info;
  const RangeMap& map = scan.map;
  info.name = map.name;
  info.source = std::move(source);
  info.camera = map.camera;
  info.T_world_scanner = map.T_world_scanner;
  info.world_box = scan_world_box(map);
  info.noise = map.noise;
  info.skipped = skipped;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x)
      if (map.has_point(x, y)) {
        ++info.points;
        info.max_depth_m = std::max(info.max_depth_m, map.camera.depth(map.points(x, y)));
      }
  return info;
}

void write_scan_file(const std::string& path, const ScanInfo& info, const ScanAo& scan) {
  write_atomically(path, [&](const std::string& partial) {
    BinaryOut out(partial);
    out.bytes(kScanMagic, kMagicSize);
    put_info(out, info);
    const RangeMap& map = scan.map;
    long long written = 0;
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x) {
        if (!map.has_point(x, y)) continue;
        PointRecord r;
        r.pixel = static_cast<std::uint32_t>(static_cast<std::size_t>(y) * map.camera.width + x);
        std::memcpy(r.point, map.points(x, y).data(), sizeof r.point);
        std::memcpy(r.normal, map.normals(x, y).data(), sizeof r.normal);
        r.ssao = scan.ssao(x, y);
        r.border_px = scan.border_px(x, y);
        out.put(r);
        ++written;
      }
    if (written != info.points)
      throw Error(ExitCode::kFailure, path + ": the scan has " + std::to_string(written) +
                                          " points, its description " +
                                          std::to_string(info.points));
    out.close();
  });
}

ScanInfo read_scan_info(const std::string& path) {
  BinaryIn in(path);
  const ScanInfo info = get_info(in);
  const std::uint64_t expected =
      in.position() + static_cast<std::uint64_t>(info.points) * sizeof(PointRecord);
  std::error_code ec;
  if (std::filesystem::file_size(path, ec) != expected || ec)
    in.fail("its size does not match its header (" + std::to_string(info.points) + " points)");
  return info;
}

void read_scan_file(const std::string& path, ScanAo& scan) {
  BinaryIn in(path);
  const ScanInfo info = get_info(in);
  RangeMap& map = scan.map;
  map.name = info.name;
  map.camera = info.camera;
  map.T_world_scanner = info.T_world_scanner;
  map.noise = info.noise;
  const int w = info.camera.width, h = info.camera.height;
  map.points.resize(w, h, Eigen::Vector3f::Zero());
  map.normals.resize(w, h, Eigen::Vector3f::Zero());
  scan.ssao.resize(w, h, 1.0f);
  scan.border_px.resize(w, h, 0.0f);
  const std::size_t pixels = info.pixels();
  std::vector<PointRecord> chunk(1 << 16);
  for (long long done = 0; done < info.points;) {
    const std::size_t n =
        static_cast<std::size_t>(std::min<long long>(info.points - done, chunk.size()));
    in.bytes(chunk.data(), n * sizeof(PointRecord));
    for (std::size_t k = 0; k < n; ++k) {
      const PointRecord& r = chunk[k];
      if (r.pixel >= pixels) in.fail("a point lies outside its map");
      const int x = static_cast<int>(r.pixel % static_cast<std::uint32_t>(w));
      const int y = static_cast<int>(r.pixel / static_cast<std::uint32_t>(w));
      map.points(x, y) = Eigen::Vector3f(r.point[0], r.point[1], r.point[2]);
      map.normals(x, y) = Eigen::Vector3f(r.normal[0], r.normal[1], r.normal[2]);
      scan.ssao(x, y) = r.ssao;
      scan.border_px(x, y) = r.border_px;
    }
    done += static_cast<long long>(n);
  }
  in.expect_end();
}

void write_mvao_file(const std::string& path, const RangeMap& map, const Image<float>& mvao,
                     long long points_shared) {
  write_atomically(path, [&](const std::string& partial) {
    BinaryOut out(partial);
    out.bytes(kValuesMagic, kMagicSize);
    out.put(static_cast<std::int64_t>(map.count_points()));
    out.put(static_cast<std::int64_t>(points_shared));
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x)
        if (map.has_point(x, y)) out.put(mvao(x, y));
    out.close();
  });
}

long long read_mvao_file(const std::string& path, const RangeMap& map, Image<float>& mvao) {
  BinaryIn in(path);
  in.magic(kValuesMagic);
  const long long count = map.count_points();
  if (in.get<std::int64_t>() != count) in.fail("it holds another scan's values");
  const long long shared = in.get<std::int64_t>();
  std::vector<float> read(static_cast<std::size_t>(count));
  in.bytes(read.data(), read.size() * sizeof(float));
  in.expect_end();
  mvao.resize(map.camera.width, map.camera.height, 1.0f);
  std::size_t k = 0;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x)
      if (map.has_point(x, y)) mvao(x, y) = read[k++];
  return shared;
}

std::optional<long long> mvao_file_shared(const std::string& path, long long points) {
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (ec || bytes != kMagicSize + 2 * sizeof(std::int64_t) + sizeof(float) * points) return {};
  try {
    BinaryIn in(path);
    in.magic(kValuesMagic);
    if (in.get<std::int64_t>() != points) return {};
    const long long shared = in.get<std::int64_t>();
    if (shared < 0 || shared > points) return {};
    return shared;
  } catch (const Error&) {
    return {};
  }
}

std::shared_ptr<const ScanAo> ScanCache::get(std::uint64_t key, std::size_t bytes) {
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->key == key) {
      entries_.splice(entries_.begin(), entries_, it);
      return it->scan;
    }
  std::shared_ptr<ScanAo> scan = trim(budget_ > bytes ? budget_ - bytes : 0, bytes);
  if (!scan) scan = std::make_shared<ScanAo>();
  load_(key, *scan);
  ++loads_;
  entries_.push_front(Entry{key, bytes, scan, true});
  held_ += bytes;
  return scan;
}

void ScanCache::put(std::uint64_t key, std::shared_ptr<const ScanAo> scan, std::size_t bytes) {
  if (bytes > budget_) return;
  trim(budget_ - bytes);
  if (held_ + bytes > budget_) return;
  // Kept as it came: never loaded into (`loaded` false), so it stays const.
  entries_.push_front(Entry{key, bytes, std::const_pointer_cast<ScanAo>(std::move(scan)), false});
  held_ += bytes;
}

std::shared_ptr<ScanAo> ScanCache::trim(std::size_t bytes, std::size_t reuse_bytes) {
  std::shared_ptr<ScanAo> reusable;
  for (auto it = entries_.end(); it != entries_.begin() && held_ > bytes;) {
    --it;
    if (it->scan.use_count() > 1) continue;
    held_ -= it->bytes;
    if (!reusable && it->loaded && reuse_bytes > 0 && it->bytes == reuse_bytes)
      reusable = std::move(it->scan);
    it = entries_.erase(it);
  }
  return reusable;
}

}  // namespace aoscan
