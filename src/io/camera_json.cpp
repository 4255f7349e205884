/// @file camera_json.cpp
/// @brief Reading and writing camera.json; the contract's default calibrations.
#include "io/camera_json.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include <Eigen/SVD>
#include <nlohmann/json.hpp>

#include "core/status.h"
#include "io/atomic_write.h"

namespace aoscan {
namespace {

constexpr int kMaxImageSide = 1 << 16;

/// SAX handler that only remembers the last object key, to name it when parsing fails.
class KeyTracker : public nlohmann::json::json_sax_t {
 public:
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(string_t& k) override {
    last_key = k;
    return true;
  }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t, const std::string& token,
                   const nlohmann::detail::exception& e) override {
    failed_token = token;
    overflow = e.id == 406;
    return false;
  }

  std::string last_key;
  std::string failed_token;
  bool overflow = false;
};

/// nlohmann messages start with "[json.exception.NAME.ID] "; keep the readable part.
std::string without_prefix(const std::string& what) {
  if (!what.empty() && what[0] == '[') {
    const auto close = what.find("] ");
    if (close != std::string::npos) return what.substr(close + 2);
  }
  return what;
}

std::string number_text(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

double positive_number(const nlohmann::json& doc, const std::string& path, const char* key,
                       bool must_be_positive) {
  const auto it = doc.find(key);
  if (it == doc.end()) throw input_error(path + ": missing key '" + key + "'");
  if (!it->is_number())
    throw input_error(path + ": key '" + key + "' is not a number (got " + it->dump() + ")");
  const double v = it->get<double>();
  if (!std::isfinite(v)) throw input_error(path + ": key '" + key + "' is not finite");
  if (must_be_positive && !(v > 0))
    throw input_error(path + ": key '" + key + "' must be positive (got " + number_text(v) + ")");
  return v;
}

/// Width or height: a positive integer (an integral float such as 640.0 is accepted).
int image_side(const nlohmann::json& value, const std::string& path, const char* key) {
  const std::string bad =
      path + ": key '" + key + "' must be a positive integer (got " + value.dump() + ")";
  if (value.is_number_integer()) {
    const auto v = value.get<std::int64_t>();
    if (value.is_number_unsigned() && value.get<std::uint64_t>() > std::uint64_t{kMaxImageSide})
      throw input_error(bad);
    if (v <= 0 || v > kMaxImageSide) throw input_error(bad);
    return static_cast<int>(v);
  }
  if (value.is_number_float()) {
    const double v = value.get<double>();
    if (!std::isfinite(v) || v != std::floor(v) || v <= 0 || v > kMaxImageSide)
      throw input_error(bad);
    return static_cast<int>(v);
  }
  throw input_error(bad);
}

std::string shortest(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  return std::string(buffer, result.ptr);
}

bool contains(const std::string& s, const char* part) {
  return s.find(part) != std::string::npos;
}

/// The `colour` object of camera.json (read_camera_json()).
ColourCamera read_colour(const nlohmann::json& doc, const std::string& path,
                         const Intrinsics& depth) {
  if (!doc.is_object()) throw input_error(path + ": key 'colour' must hold a JSON object");
  const auto registered = doc.find("registered");
  if (registered != doc.end() && !registered->is_boolean())
    throw input_error(path + ": key 'colour.registered' must be true or false (got " +
                      registered->dump() + ")");
  if (registered != doc.end() && registered->get<bool>()) {
    if (doc.size() != 1)
      throw input_error(path + ": a registered colour camera takes no other key than "
                               "'colour.registered'");
    return ColourCamera::registered_to(depth);
  }
  const std::string prefix = path + " (colour)";
  ColourCamera c;
  c.intrinsics.fx = positive_number(doc, prefix, "fx", true);
  c.intrinsics.fy = positive_number(doc, prefix, "fy", true);
  c.intrinsics.cx = positive_number(doc, prefix, "cx", false);
  c.intrinsics.cy = positive_number(doc, prefix, "cy", false);
  const auto width = doc.find("width");
  const auto height = doc.find("height");
  if (width == doc.end() || height == doc.end())
    throw input_error(path + ": keys 'colour.width' and 'colour.height' are required");
  c.intrinsics.width = image_side(*width, prefix, "width");
  c.intrinsics.height = image_side(*height, prefix, "height");
  const auto m = doc.find("depth_to_colour");
  if (m == doc.end()) throw input_error(path + ": missing key 'colour.depth_to_colour'");
  if (!m->is_array() || m->size() != 12)
    throw input_error(path + ": key 'colour.depth_to_colour' must be an array of 12 numbers "
                             "(the 3x4 matrix [R | t], row by row)");
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  for (int i = 0; i < 12; ++i) {
    const nlohmann::json& e = (*m)[static_cast<std::size_t>(i)];
    if (!e.is_number() || !std::isfinite(e.get<double>()))
      throw input_error(path + ": key 'colour.depth_to_colour' element " + std::to_string(i) +
                        " is not a finite number (got " + e.dump() + ")");
    const double v = e.get<double>();
    if (i % 4 == 3)
      t(i / 4) = v;
    else
      R(i / 4, i % 4) = v;
  }
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-3 ||
      R.determinant() < 0.0)
    throw input_error(path + ": key 'colour.depth_to_colour' is not a rotation and a "
                             "translation (R^T R must be the identity within 1e-3, det R = +1)");
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  c.T_colour_depth = Pose(svd.matrixU() * svd.matrixV().transpose(), t);
  return c;
}

}  // namespace

CameraInfo read_camera_json(const std::string& path, int default_width, int default_height) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path + ": cannot open camera file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw input_error(path + ": cannot read camera file");
  const std::string text = buffer.str();

  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    KeyTracker tracker;
    nlohmann::json::sax_parse(text, &tracker);
    if (tracker.overflow && !tracker.last_key.empty())
      throw input_error(path + ": key '" + tracker.last_key + "' is out of range (" +
                        tracker.failed_token + ")");
    std::string where = tracker.last_key.empty() ? "" : " (after key '" + tracker.last_key + "')";
    throw input_error(path + ": invalid JSON" + where + ": " + without_prefix(e.what()));
  }
  if (!doc.is_object()) throw input_error(path + ": camera file must hold a JSON object");

  CameraInfo info;
  info.intrinsics.fx = positive_number(doc, path, "fx", true);
  info.intrinsics.fy = positive_number(doc, path, "fy", true);
  info.intrinsics.cx = positive_number(doc, path, "cx", false);
  info.intrinsics.cy = positive_number(doc, path, "cy", false);
  info.depth_scale = positive_number(doc, path, "depth_scale", true);

  const auto width = doc.find("width");
  const auto height = doc.find("height");
  if ((width == doc.end()) != (height == doc.end()))
    throw input_error(path + ": keys 'width' and 'height' must be given together");
  if (width != doc.end()) {
    info.intrinsics.width = image_side(*width, path, "width");
    info.intrinsics.height = image_side(*height, path, "height");
    info.size_given = true;
  } else {
    info.intrinsics.width = default_width;
    info.intrinsics.height = default_height;
  }
  const auto colour = doc.find("colour");
  if (colour != doc.end()) info.colour = read_colour(*colour, path, info.intrinsics);
  info.origin = path;
  return info;
}

void write_camera_json(const std::string& path, const Intrinsics& intrinsics, double depth_scale,
                       const ColourCamera* colour) {
  if (!intrinsics.valid() || !std::isfinite(depth_scale) || !(depth_scale > 0) ||
      (colour != nullptr && !colour->intrinsics.valid()))
    throw usage_error(path + ": refusing to write invalid calibration");
  const auto pinhole = [](const Intrinsics& k) {
    return "\"width\": " + std::to_string(k.width) + ", \"height\": " + std::to_string(k.height) +
           ", \"fx\": " + shortest(k.fx) + ", \"fy\": " + shortest(k.fy) +
           ", \"cx\": " + shortest(k.cx) + ", \"cy\": " + shortest(k.cy);
  };
  std::string colour_text;
  if (colour != nullptr && colour->registered) {
    colour_text = ",\n  \"colour\": { \"registered\": true }";
  } else if (colour != nullptr) {
    colour_text = ",\n  \"colour\": { " + pinhole(colour->intrinsics) + ",\n    \"depth_to_colour\": [";
    const Eigen::Matrix4d m = colour->T_colour_depth.matrix();
    for (int i = 0; i < 12; ++i)
      colour_text += (i == 0 ? "" : i % 4 == 0 ? ",\n      " : ", ") + shortest(m(i / 4, i % 4));
    colour_text += "] }";
  }
  const std::string text = "{ " + pinhole(intrinsics) +
                           ", \"depth_scale\": " + shortest(depth_scale) + colour_text + " }\n";
  write_atomically(path, [&text](const std::string& partial) {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw Error(ExitCode::kFailure, partial + ": cannot write camera file");
  });
}

CameraInfo default_camera_for_folder(const std::string& folder) {
  namespace fs = std::filesystem;
  fs::path p = fs::path(folder).lexically_normal();
  if (!p.has_filename()) p = p.parent_path();  // "dir/" -> "dir"
  std::string name = p.filename().string();
  if (name.empty() || name == "." || name == "..") {
    std::error_code ec;
    const fs::path absolute = fs::absolute(p, ec).lexically_normal();
    if (!ec)
      name = (absolute.has_filename() ? absolute : absolute.parent_path()).filename().string();
  }

  // TUM RGB-D calibrations of the freiburg1/2/3 depth cameras, then the generic Kinect default.
  struct Calibration {
    const char* tag;
    double fx, fy, cx, cy;
  };
  static constexpr Calibration kCalibrations[] = {
      {"freiburg1", 517.3, 516.5, 318.6, 255.3},
      {"freiburg2", 520.9, 521.0, 325.1, 249.7},
      {"freiburg3", 535.4, 539.2, 320.1, 247.6},
  };
  CameraInfo info;
  info.depth_scale = 5000.0;
  info.intrinsics = Intrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};
  info.origin = "the default calibration (no camera.json)";
  info.is_default = true;
  for (const Calibration& c : kCalibrations) {
    if (contains(name, c.tag)) {
      info.intrinsics = Intrinsics{640, 480, c.fx, c.fy, c.cx, c.cy};
      info.origin = std::string("the TUM ") + c.tag + " calibration (folder name, no camera.json)";
      info.is_default = false;
      break;
    }
  }
  return info;
}

}  // namespace aoscan
