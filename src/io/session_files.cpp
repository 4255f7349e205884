/// @file session_files.cpp
/// @brief Byte layouts of the keyframe and grid files of a saved session.
#include "io/session_files.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include <Eigen/LU>

#include "core/status.h"
#include "io/atomic_write.h"

namespace aoscan {
namespace {

constexpr char kKeyframesMagic[8] = {'A', 'O', 'S', 'C', 'K', 'F', 'D', 'B'};
constexpr char kGridMagic[8] = {'A', 'O', 'S', 'C', 'M', 'V', 'A', 'O'};

std::uint64_t fnv1a(const std::string& bytes) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

/// Little-endian appends (the machines aoscan runs on are little-endian: the bytes as they lie).
template <class T>
void put(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

/// Reads values from a file's bytes, each check naming the file.
class Reader {
 public:
  Reader(std::string path, std::string bytes) : path_(std::move(path)), bytes_(std::move(bytes)) {}

  template <class T>
  T get() {
    need(sizeof(T));
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  void need(std::size_t n) const {
    if (n > bytes_.size() - at_) fail("truncated");
  }
  std::size_t left() const { return bytes_.size() - at_; }
  const char* data() const { return bytes_.data() + at_; }
  void skip(std::size_t n) {
    need(n);
    at_ += n;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw input_error(path_ + ": " + what + " (a damaged or foreign session file)");
  }

 private:
  std::string path_;
  std::string bytes_;
  std::size_t at_ = 0;
};

/// The file's bytes after its magic and version are checked and its checksum verified.
Reader open_checked(const std::string& path, const char (&magic)[8]) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path + ": cannot be read");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw input_error(path + ": cannot be read");
  if (bytes.size() < sizeof(magic) + sizeof(std::uint32_t) + sizeof(std::uint64_t) ||
      std::memcmp(bytes.data(), magic, sizeof(magic)) != 0)
    throw input_error(path + ": not a session file of aoscan");
  std::uint32_t version;
  std::memcpy(&version, bytes.data() + sizeof(magic), sizeof(version));
  if (version != kSessionFormatVersion)
    throw input_error(path + ": session format version " + std::to_string(version) +
                      ", this aoscan reads version " + std::to_string(kSessionFormatVersion));
  std::uint64_t stored;
  std::memcpy(&stored, bytes.data() + bytes.size() - sizeof(stored), sizeof(stored));
  bytes.resize(bytes.size() - sizeof(stored));
  if (fnv1a(bytes) != stored)
    throw input_error(path + ": checksum mismatch (a truncated or damaged session file)");
  Reader reader(path, std::move(bytes));
  reader.skip(sizeof(magic) + sizeof(version));
  return reader;
}

/// Appends the checksum and writes `bytes` to `path` atomically.
void write_checked(const std::string& path, std::string bytes) {
  put(bytes, fnv1a(bytes));
  write_atomically(path, [&](const std::string& partial) {
    std::ofstream out(partial, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw Error(ExitCode::kFailure, partial + ": cannot be written");
  });
}

std::string header(const char (&magic)[8]) {
  std::string out(magic, sizeof(magic));
  put(out, kSessionFormatVersion);
  return out;
}

}  // namespace

void write_keyframes(const std::string& path, const SavedKeyframes& keyframes) {
  std::string out = header(kKeyframesMagic);
  put(out, keyframes.ferns);
  put(out, keyframes.fern_decisions);
  put(out, static_cast<std::uint64_t>(keyframes.keyframes.size()));
  for (const SavedKeyframe& k : keyframes.keyframes) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) put(out, k.T_world_camera(r, c));
    if (k.codes.size() != keyframes.ferns)
      throw Error(ExitCode::kFailure, path + ": a keyframe's codes do not match its ferns");
    out.append(reinterpret_cast<const char*>(k.codes.data()), k.codes.size());
    put(out, static_cast<std::uint32_t>(k.depth_mm.width()));
    put(out, static_cast<std::uint32_t>(k.depth_mm.height()));
    out.append(reinterpret_cast<const char*>(k.depth_mm.data()),
               k.depth_mm.size() * sizeof(std::uint16_t));
  }
  write_checked(path, std::move(out));
}

SavedKeyframes read_keyframes(const std::string& path, std::size_t max_keyframes) {
  Reader in = open_checked(path, kKeyframesMagic);
  SavedKeyframes result;
  result.ferns = in.get<std::uint32_t>();
  result.fern_decisions = in.get<std::uint32_t>();
  const std::uint64_t count = in.get<std::uint64_t>();
  if (result.fern_decisions < 1 || result.fern_decisions > 8) in.fail("bad fern decisions");
  if (count > max_keyframes)
    throw input_error(path + ": holds " + std::to_string(count) +
                      " keyframes, more than relocalisation.max_keyframes (" +
                      std::to_string(max_keyframes) + ") allows");
  // Each keyframe takes at least its pose, codes and image size: a count the file cannot hold is
  // refused before anything is allocated for it.
  const std::size_t least = 12 * sizeof(double) + result.ferns + 2 * sizeof(std::uint32_t);
  if (count > in.left() / least) in.fail("truncated");
  result.keyframes.resize(count);
  for (SavedKeyframe& k : result.keyframes) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) k.T_world_camera(r, c) = in.get<double>();
    const Eigen::Matrix3d R = k.T_world_camera.topLeftCorner<3, 3>();
    if (!k.T_world_camera.allFinite() ||
        !(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || R.determinant() < 0)
      in.fail("a keyframe's pose is not a rigid transform");
    in.need(result.ferns);
    k.codes.assign(in.data(), in.data() + result.ferns);
    in.skip(result.ferns);
    for (const std::uint8_t c : k.codes)
      if (c >> result.fern_decisions) in.fail("a fern code wider than its decisions");
    const std::uint32_t w = in.get<std::uint32_t>(), h = in.get<std::uint32_t>();
    const std::uint64_t pixels = static_cast<std::uint64_t>(w) * h;
    if (pixels > in.left() / sizeof(std::uint16_t)) in.fail("truncated");
    k.depth_mm.resize(static_cast<int>(w), static_cast<int>(h));
    std::memcpy(k.depth_mm.data(), in.data(), pixels * sizeof(std::uint16_t));
    in.skip(pixels * sizeof(std::uint16_t));
  }
  if (in.left() != 0) in.fail("trailing bytes");
  return result;
}

void write_grid(const std::string& path, const SavedGrid& grid) {
  std::string out = header(kGridMagic);
  put(out, grid.cell_size_m);
  put(out, grid.integration);
  put(out, grid.frames);
  put(out, static_cast<std::uint64_t>(grid.cells.size()));
  for (const SavedCell& c : grid.cells) {
    put(out, c.x);
    put(out, c.y);
    put(out, c.z);
    put(out, c.ao_weight_sum);
    put(out, c.weight_sum);
    put(out, c.last_frame);
  }
  write_checked(path, std::move(out));
}

SavedGrid read_grid(const std::string& path) {
  Reader in = open_checked(path, kGridMagic);
  SavedGrid grid;
  grid.cell_size_m = in.get<double>();
  grid.integration = in.get<std::uint32_t>();
  grid.frames = in.get<std::uint64_t>();
  const std::uint64_t count = in.get<std::uint64_t>();
  if (!(std::isfinite(grid.cell_size_m) && grid.cell_size_m > 0.0)) in.fail("bad cell size");
  constexpr std::size_t kCellBytes = 3 * sizeof(std::int32_t) + 2 * sizeof(float) + 4;
  if (count != in.left() / kCellBytes || in.left() % kCellBytes != 0) in.fail("truncated");
  grid.cells.resize(count);
  for (SavedCell& c : grid.cells) {
    c.x = in.get<std::int32_t>();
    c.y = in.get<std::int32_t>();
    c.z = in.get<std::int32_t>();
    c.ao_weight_sum = in.get<float>();
    c.weight_sum = in.get<float>();
    c.last_frame = in.get<std::uint32_t>();
    if (!std::isfinite(c.ao_weight_sum) || !std::isfinite(c.weight_sum) || c.weight_sum < 0.0f ||
        c.ao_weight_sum < 0.0f)
      in.fail("a cell with a non-finite or negative weight");
  }
  return grid;
}

}  // namespace aoscan
