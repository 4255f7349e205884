/// @file ply.cpp
/// @brief PLY writing (binary little-endian, fixed layout) and reading (binary LE and ASCII).
#include "io/ply.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string_view>
#include <vector>

#include "core/checked_close.h"
#include "core/status.h"
#include "io/atomic_write.h"
#include "io/tokens.h"

namespace aoscan {
namespace {

// ---- writing ----------------------------------------------------------------------------------

void put_u32(std::vector<unsigned char>& out, std::uint32_t v) {
  const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8),
                              static_cast<unsigned char>(v >> 16),
                              static_cast<unsigned char>(v >> 24)};
  out.insert(out.end(), b, b + 4);
}

void put_f32(std::vector<unsigned char>& out, float f) {
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  put_u32(out, bits);
}

float load_f32(const unsigned char* b) {
  std::uint32_t bits = static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
                       static_cast<std::uint32_t>(b[2]) << 16 | static_cast<std::uint32_t>(b[3]) << 24;
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// ---- reading ----------------------------------------------------------------------------------

enum class Type { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool parse_type(std::string_view name, Type& type) {
  static const std::pair<const char*, Type> kNames[] = {
      {"char", Type::kInt8},      {"int8", Type::kInt8},       {"uchar", Type::kUint8},
      {"uint8", Type::kUint8},    {"short", Type::kInt16},     {"int16", Type::kInt16},
      {"ushort", Type::kUint16},  {"uint16", Type::kUint16},   {"int", Type::kInt32},
      {"int32", Type::kInt32},    {"uint", Type::kUint32},     {"uint32", Type::kUint32},
      {"float", Type::kFloat32},  {"float32", Type::kFloat32}, {"double", Type::kFloat64},
      {"float64", Type::kFloat64}};
  for (const auto& [n, t] : kNames)
    if (name == n) {
      type = t;
      return true;
    }
  return false;
}

std::size_t type_size(Type t) {
  switch (t) {
    case Type::kInt8:
    case Type::kUint8:
      return 1;
    case Type::kInt16:
    case Type::kUint16:
      return 2;
    case Type::kInt32:
    case Type::kUint32:
    case Type::kFloat32:
      return 4;
    case Type::kFloat64:
      return 8;
  }
  return 1;
}

struct Property {
  std::string name;
  Type type = Type::kFloat32;
  bool is_list = false;
  Type count_type = Type::kUint8;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

/// Sequential reader of the data section, binary little-endian or ASCII.
class DataReader {
 public:
  DataReader(const std::string& path, std::string_view data, bool ascii)
      : path_(path), data_(data), ascii_(ascii) {}

  /// The next value of type `t` as a double; `what` names the element instance for messages.
  double next(Type t, const char* what, std::uint64_t index) {
    return ascii_ ? next_ascii(what, index) : next_binary(t, what, index);
  }
  std::size_t remaining() const { return data_.size() - pos_; }

  /// The next `n` bytes (binary data), or a truncation error.
  const unsigned char* take(std::size_t n, const char* what, std::uint64_t index) {
    if (remaining() < n) truncated(what, index);
    const auto* p = reinterpret_cast<const unsigned char*>(data_.data() + pos_);
    pos_ += n;
    return p;
  }

  /// A little-endian value of type `t` at `b`.
  static double decode(Type t, const unsigned char* b) {
    const std::size_t n = type_size(t);
    std::uint64_t u = 0;
    for (std::size_t i = 0; i < n; ++i) u |= static_cast<std::uint64_t>(b[i]) << (8 * i);
    switch (t) {
      case Type::kInt8:
        return static_cast<std::int8_t>(u);
      case Type::kUint8:
        return static_cast<double>(u);
      case Type::kInt16:
        return static_cast<std::int16_t>(u);
      case Type::kUint16:
        return static_cast<double>(u);
      case Type::kInt32:
        return static_cast<std::int32_t>(static_cast<std::uint32_t>(u));
      case Type::kUint32:
        return static_cast<double>(u);
      case Type::kFloat32: {
        const auto bits = static_cast<std::uint32_t>(u);
        float f;
        std::memcpy(&f, &bits, sizeof f);
        return f;
      }
      case Type::kFloat64: {
        double d;
        std::memcpy(&d, &u, sizeof d);
        return d;
      }
    }
    return 0.0;
  }


 private:
  [[noreturn]] void truncated(const char* what, std::uint64_t index) const {
    throw input_error(path_ + ": truncated or malformed PLY data at " + what + " " +
                      std::to_string(index));
  }

  double next_binary(Type t, const char* what, std::uint64_t index) {
    return decode(t, take(type_size(t), what, index));
  }

  double next_ascii(const char* what, std::uint64_t index) {
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    if (pos_ == start) truncated(what, index);
    const char* first = data_.data() + start;
    const char* last = data_.data() + pos_;
    if (*first == '+') ++first;
    double v = 0;
    const auto result = std::from_chars(first, last, v);
    if (result.ec != std::errc() || result.ptr != last) truncated(what, index);
    return v;
  }

  const std::string& path_;
  std::string_view data_;
  bool ascii_;
  std::size_t pos_ = 0;
};

/// Smallest number of bytes (binary) or tokens (ASCII) one instance of `e` takes.
std::uint64_t min_instance_size(const Element& e, bool ascii) {
  std::uint64_t n = 0;
  for (const Property& p : e.properties)
    n += ascii ? 1 : type_size(p.is_list ? p.count_type : p.type);
  return std::max<std::uint64_t>(n, 1);
}

}  // namespace

std::string ply_header(std::size_t vertex_count, std::size_t face_count, bool face_element) {
  const std::string faces = face_element ? "element face " + std::to_string(face_count) +
                                               "\nproperty list uchar int vertex_indices\n"
                                         : std::string();
  return "ply\n"
         "format binary_little_endian 1.0\n"
         "element vertex " +
         std::to_string(vertex_count) +
         "\n"
         "property float x\n"
         "property float y\n"
         "property float z\n"
         "property float nx\n"
         "property float ny\n"
         "property float nz\n"
         "property float quality\n"
         "property uchar red\n"
         "property uchar green\n"
         "property uchar blue\n" +
         faces + "end_header\n";
}

PlyWriter::PlyWriter(const std::string& path, std::size_t vertex_count, std::size_t face_count,
                     bool face_element)
    : path_(path), vertices_left_(vertex_count), faces_left_(face_element ? face_count : 0) {
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw_write_failed(path);
  buffer_.reserve(kChunk + 64);
  if (!face_element && face_count != 0)
    throw usage_error(path + ": a point cloud has no faces");
  const std::string header = ply_header(vertex_count, face_count, face_element);
  buffer_.insert(buffer_.end(), header.begin(), header.end());
}

PlyWriter::~PlyWriter() {
  if (file_) std::fclose(file_);
}

void PlyWriter::vertex(const Eigen::Vector3f& p, const Eigen::Vector3f& n, float quality) {
  vertex(p, n, quality, ao_grey(quality));
}

void PlyWriter::vertex(const Eigen::Vector3f& p, const Eigen::Vector3f& n, float quality,
                       const Rgb8& colour) {
  if (vertices_left_ == 0) throw usage_error(path_ + ": more vertices than the header says");
  --vertices_left_;
  for (int k = 0; k < 3; ++k) put_f32(buffer_, p[k]);
  for (int k = 0; k < 3; ++k) put_f32(buffer_, n[k]);
  put_f32(buffer_, quality);
  buffer_.insert(buffer_.end(), {colour.r, colour.g, colour.b});
  if (buffer_.size() >= kChunk) flush();
}

void PlyWriter::face(const Eigen::Vector3i& f) {
  if (vertices_left_ != 0 || faces_left_ == 0)
    throw usage_error(path_ + ": a face before the last vertex, or more faces than the header says");
  --faces_left_;
  buffer_.push_back(3);
  for (int k = 0; k < 3; ++k) put_u32(buffer_, static_cast<std::uint32_t>(f[k]));
  if (buffer_.size() >= kChunk) flush();
}

void PlyWriter::flush() {
  if (ok_ && !buffer_.empty())
    ok_ = std::fwrite(buffer_.data(), 1, buffer_.size(), file_) == buffer_.size();
  buffer_.clear();
}

void PlyWriter::finish() {
  if (vertices_left_ != 0 || faces_left_ != 0)
    throw usage_error(path_ + ": " + std::to_string(vertices_left_) + " vertices and " +
                      std::to_string(faces_left_) + " faces fewer than the header says");
  flush();
  const bool written = ok_;
  close_checked(file_, path_);  // a short write also set the file's error indicator
  if (!written) throw_write_failed(path_);
}

namespace {

/// write_ply(), or with `points` write_points_ply().
void write_ply_file(const std::string& path, const TriangleMesh& mesh,
                    const MeshWriteOptions& options, bool points) {
  check_mesh_for_writing(path, mesh);
  const std::size_t n = mesh.vertices.size();
  write_atomically(path, [&mesh, &options, n, points](const std::string& partial) {
    PlyWriter writer(partial, n, points ? 0 : mesh.faces.size(), !points);
    for (std::size_t i = 0; i < n; ++i)
      writer.vertex(mesh.vertices[i],
                    mesh.normals.empty() ? Eigen::Vector3f::Zero() : mesh.normals[i],
                    mesh.quality.empty() ? 1.0f : mesh.quality[i],
                    written_colour(mesh, i, options));
    if (!points)
      for (const Eigen::Vector3i& face : mesh.faces) writer.face(face);
    writer.finish();
  });
}

}  // namespace

void write_ply(const std::string& path, const TriangleMesh& mesh, const MeshWriteOptions& options) {
  write_ply_file(path, mesh, options, false);
}

void write_points_ply(const std::string& path, const TriangleMesh& mesh,
                      const MeshWriteOptions& options) {
  write_ply_file(path, mesh, options, true);
}

namespace {


/// The header of a PLY file: its format, its elements, and where the data begin.
struct PlyHeader {
  bool ascii = false;
  std::vector<Element> elements;
  std::size_t data_offset = 0;  ///< first byte after the end_header line
};

/// Parses the header lines of `text` (the whole file) up to and including "end_header".
PlyHeader parse_header(const std::string& path, const std::string& text) {
  std::size_t pos = 0;
  auto next_line = [&](std::string_view& line) {
    if (pos >= text.size()) return false;
    auto end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    line = std::string_view(text).substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = std::min(end + 1, text.size());
    return true;
  };
  std::string_view line;
  if (!next_line(line) || line != "ply") throw input_error(path + ": not a PLY file");
  PlyHeader header;
  bool have_format = false, ended = false;
  while (next_line(line)) {
    const auto tokens = split_tokens(line);
    if (tokens.empty() || tokens[0] == "comment" || tokens[0] == "obj_info") continue;
    const std::string bad =
        path + ": bad PLY header line '" + std::string(line.substr(0, 60)) + "'";
    if (tokens[0] == "end_header") {
      ended = true;
      break;
    } else if (tokens[0] == "format") {
      if (tokens.size() != 3) throw input_error(bad);
      if (tokens[1] == "ascii") {
        header.ascii = true;
      } else if (tokens[1] != "binary_little_endian") {
        throw input_error(path + ": unsupported PLY format '" + std::string(tokens[1]) + "'");
      }
      have_format = true;
    } else if (tokens[0] == "element") {
      if (tokens.size() != 3) throw input_error(bad);
      Element e;
      e.name = std::string(tokens[1]);
      const auto r =
          std::from_chars(tokens[2].data(), tokens[2].data() + tokens[2].size(), e.count);
      if (r.ec != std::errc() || r.ptr != tokens[2].data() + tokens[2].size())
        throw input_error(bad);
      header.elements.push_back(std::move(e));
    } else if (tokens[0] == "property") {
      if (header.elements.empty()) throw input_error(bad);
      Property p;
      if (tokens.size() == 3 && parse_type(tokens[1], p.type)) {
        p.name = std::string(tokens[2]);
      } else if (tokens.size() == 5 && tokens[1] == "list" && parse_type(tokens[2], p.count_type) &&
                 parse_type(tokens[3], p.type)) {
        p.is_list = true;
        p.name = std::string(tokens[4]);
      } else {
        throw input_error(bad);
      }
      header.elements.back().properties.push_back(std::move(p));
    } else {
      throw input_error(bad);
    }
  }
  if (!ended) throw input_error(path + ": PLY header has no end_header");
  if (!have_format) throw input_error(path + ": PLY header has no format line");
  header.data_offset = pos;
  return header;
}

/// Column roles of the vertex element `e`: 0-2 position, 3-5 normal (only when all three are
/// there), 6 quality, 7-9 red, green, blue (only when all three are there), -1 ignored. Sizes
/// the mesh's vertex arrays for the columns it has.
std::vector<int> vertex_roles(const std::string& path, const Element& e, TriangleMesh& mesh) {
  std::vector<int> role(e.properties.size(), -1);
  static const char* kNames[] = {"x", "y", "z", "nx", "ny", "nz", "quality", "red", "green", "blue"};
  constexpr int kRoles = 10;
  bool found[kRoles] = {};
  for (std::size_t i = 0; i < e.properties.size(); ++i)
    for (int r = 0; r < kRoles; ++r)
      if (e.properties[i].name == kNames[r] && !e.properties[i].is_list) {
        role[i] = r;
        found[r] = true;
      }
  if (!found[0] || !found[1] || !found[2])
    throw input_error(path + ": PLY vertex element lacks x, y or z");
  const bool normals = found[3] && found[4] && found[5];
  if (!normals)
    for (int& r : role)
      if (r >= 3 && r <= 5) r = -1;
  const bool colours = found[7] && found[8] && found[9];
  if (!colours)
    for (int& r : role)
      if (r >= 7) r = -1;
  mesh.vertices.resize(e.count);
  if (normals) mesh.normals.resize(e.count);
  if (found[6]) mesh.quality.resize(e.count);
  if (colours) mesh.colours.resize(e.count);
  return role;
}

/// Reads the instances of element `e` from `reader`: vertex columns with a role (vertex_roles())
/// and the polygons of the face list column `face_list` (fanned into triangles) go into `mesh`;
/// everything else is read and dropped. `have_vertices`: a vertex element came before.
void read_element(const std::string& path, const Element& e, const std::vector<int>& role,
                  int face_list, bool have_vertices, bool ascii, DataReader& reader,
                  TriangleMesh& mesh) {
  const bool is_vertex = e.name == "vertex";
  const char* what = e.name.c_str();
  // Vertex `index`'s value `f` of the column with role `r` (0-2 position, 3-5 normal, 6 quality,
  // 7-9 colour: rounded and clamped to 0-255).
  const auto store = [&mesh](std::uint64_t index, int r, float f) {
    if (r < 3) {
      mesh.vertices[index][r] = f;
    } else if (r < 6) {
      mesh.normals[index][r - 3] = f;
    } else if (r == 6) {
      mesh.quality[index] = f;
    } else {
      const auto c = static_cast<std::uint8_t>(f >= 255.0f ? 255.0f : f > 0.0f ? f + 0.5f : 0.0f);
      Rgb8& colour = mesh.colours[index];
      (r == 7 ? colour.r : r == 8 ? colour.g : colour.b) = c;
    }
  };
  const bool fixed = std::none_of(e.properties.begin(), e.properties.end(),
                                  [](const Property& p) { return p.is_list; });
  if (!ascii && fixed) {
    // Binary rows of one size: each taken whole, its columns decoded at their offsets.
    std::vector<std::size_t> offset;
    std::size_t row = 0;
    for (const Property& p : e.properties) {
      offset.push_back(row);
      row += type_size(p.type);
    }
    for (std::uint64_t index = 0; index < e.count; ++index) {
      const unsigned char* b = reader.take(row, what, index);
      if (!is_vertex) continue;
      for (std::size_t i = 0; i < e.properties.size(); ++i) {
        const int r = role[i];
        if (r < 0) continue;
        const float f = e.properties[i].type == Type::kFloat32
                            ? load_f32(b + offset[i])
                            : static_cast<float>(DataReader::decode(e.properties[i].type, b + offset[i]));
        store(index, r, f);
      }
    }
    return;
  }
  std::vector<int> polygon;
  for (std::uint64_t index = 0; index < e.count; ++index) {
    for (std::size_t i = 0; i < e.properties.size(); ++i) {
      const Property& p = e.properties[i];
      if (!p.is_list) {
        const double v = reader.next(p.type, what, index);
        if (is_vertex && role[i] >= 0) store(index, role[i], static_cast<float>(v));
        continue;
      }
      const double count = reader.next(p.count_type, what, index);
      if (!(count >= 0) || count != std::floor(count))
        throw input_error(path + ": bad list length in " + e.name + " " + std::to_string(index));
      if (count > static_cast<double>(reader.remaining()))  // every item takes a byte at least
        throw input_error(path + ": truncated PLY data at " + e.name + " " +
                          std::to_string(index));
      polygon.clear();
      for (int k = 0; k < static_cast<int>(count); ++k) {
        const double v = reader.next(p.type, what, index);
        if (static_cast<int>(i) == face_list) {
          if (!have_vertices || !(v >= 0) || v >= static_cast<double>(mesh.vertices.size()) ||
              v != std::floor(v))
            throw input_error(path + ": face " + std::to_string(index) +
                              " has a vertex index out of range");
          polygon.push_back(static_cast<int>(v));
        }
      }
      if (static_cast<int>(i) == face_list) {
        if (polygon.size() < 3)
          throw input_error(path + ": face " + std::to_string(index) +
                            " has fewer than 3 vertices");
        for (std::size_t k = 1; k + 1 < polygon.size(); ++k)
          mesh.faces.emplace_back(polygon[0], polygon[k], polygon[k + 1]);
      }
    }
  }
}

}  // namespace

TriangleMesh read_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw input_error(path + ": cannot open PLY file");
  const std::streamoff size = in.tellg();
  if (size < 0) throw input_error(path + ": cannot read PLY file");
  std::string text(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  if (!in.read(text.data(), size)) throw input_error(path + ": cannot read PLY file");
  const PlyHeader header = parse_header(path, text);

  DataReader reader(path, std::string_view(text).substr(header.data_offset), header.ascii);
  TriangleMesh mesh;
  bool have_vertices = false;
  for (const Element& e : header.elements) {
    if (e.count > reader.remaining() / min_instance_size(e, header.ascii) + 1)
      throw input_error(path + ": truncated PLY data, too short for " + std::to_string(e.count) +
                        " " + e.name + " elements");
    std::vector<int> role(e.properties.size(), -1);
    if (e.name == "vertex") {
      // A second vertex element would resize the positions but not the quality or normals of
      // the first: the mesh's arrays would disagree.
      if (have_vertices) throw input_error(path + ": PLY has more than one vertex element");
      role = vertex_roles(path, e, mesh);
      have_vertices = true;
    }
    int face_list = -1;
    if (e.name == "face")
      for (std::size_t i = 0; i < e.properties.size(); ++i)
        if (e.properties[i].is_list &&
            (e.properties[i].name == "vertex_indices" || e.properties[i].name == "vertex_index"))
          face_list = static_cast<int>(i);
    read_element(path, e, role, face_list, have_vertices, header.ascii, reader, mesh);
  }
  return mesh;
}

}  // namespace aoscan
