/// @file scan_manifest.cpp
/// @brief Reading scan manifests (JSON or YAML, through yaml-cpp).
#include "io/scan_manifest.h"

#include <cmath>
#include <filesystem>
#include <system_error>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>

#include "core/status.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

/// Reports a problem with scan `index` (and its name, once known) of manifest `path`.
struct Context {
  std::string path;
  std::size_t index = 0;
  std::string name;

  [[noreturn]] void fail(const std::string& what) const {
    throw input_error(path + ": scan " + std::to_string(index + 1) +
                      (name.empty() ? "" : " (" + name + ")") + ": " + what);
  }
};

double number(const YAML::Node& node, const Context& c, const std::string& key) {
  try {
    const double v = node.as<double>();
    if (!std::isfinite(v)) c.fail(key + " is not finite");
    return v;
  } catch (const YAML::Exception&) {
    c.fail(key + " is not a number");
  }
}

std::vector<double> numbers(const YAML::Node& node, std::size_t count, const Context& c,
                            const std::string& key) {
  if (!node.IsSequence() || node.size() != count)
    c.fail(key + " must be a list of " + std::to_string(count) + " numbers");
  std::vector<double> out;
  for (const YAML::Node& v : node) out.push_back(number(v, c, key));
  return out;
}

Pose read_pose(const YAML::Node& node, const Context& c) {
  if (!node) return Pose::identity();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (node.IsSequence()) {
    const std::vector<double> v = numbers(node, 16, c, "pose");
    for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = v[i];
    if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
      c.fail("pose: the last row of a 4 x 4 pose must be 0 0 0 1");
  } else if (node.IsMap() && node["t"] && node["q"] && node.size() == 2) {
    const std::vector<double> t = numbers(node["t"], 3, c, "pose.t");
    const std::vector<double> q = numbers(node["q"], 4, c, "pose.q");
    const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
    if (!(quat.norm() > 1e-9)) c.fail("pose.q is not a rotation (zero quaternion)");
    m.topLeftCorner<3, 3>() = quat.normalized().toRotationMatrix();
    m.topRightCorner<3, 1>() = Eigen::Vector3d(t[0], t[1], t[2]);
  } else {
    c.fail(
        "pose must be 16 numbers (a 4 x 4 matrix, row-major) or {t: [x, y, z], q: [qx, qy, "
        "qz, qw]}");
  }
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-4 || R.determinant() < 0.0)
    c.fail("pose is not a rigid transform (its rotation is not orthonormal)");
  return Pose::from_matrix(m).normalized();
}

Intrinsics read_camera(const YAML::Node& node, const Context& c, double& depth_scale) {
  if (!node || !node.IsMap()) c.fail("a depth scan needs camera: {fx, fy, cx, cy, depth_scale}");
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    if (key != "fx" && key != "fy" && key != "cx" && key != "cy" && key != "depth_scale")
      throw usage_error(c.path + ": scan " + std::to_string(c.index + 1) +
                        ": unknown camera key '" + key + "' (fx, fy, cx, cy, depth_scale)");
  }
  Intrinsics k;
  for (const char* key : {"fx", "fy", "cx", "cy", "depth_scale"})
    if (!node[key]) c.fail(std::string("camera lacks ") + key);
  k.fx = number(node["fx"], c, "camera.fx");
  k.fy = number(node["fy"], c, "camera.fy");
  k.cx = number(node["cx"], c, "camera.cx");
  k.cy = number(node["cy"], c, "camera.cy");
  depth_scale = number(node["depth_scale"], c, "camera.depth_scale");
  if (!(k.fx > 0.0 && k.fy > 0.0 && depth_scale > 0.0))
    c.fail("camera: fx, fy and depth_scale must be positive");
  return k;
}

ScanEntry read_entry(const YAML::Node& node, const fs::path& base, Context& c) {
  if (!node.IsMap()) c.fail("each scan must be a map of keys");
  static const std::set<std::string> kKeys = {"name",   "depth", "points",
                                              "camera", "pose",  "scanner"};
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    if (!kKeys.count(key))
      throw usage_error(c.path + ": scan " + std::to_string(c.index + 1) + ": unknown key '" + key +
                        "' (name, depth, camera, points, scanner, pose)");
  }
  ScanEntry e;
  const bool depth = static_cast<bool>(node["depth"]);
  const bool points = static_cast<bool>(node["points"]);
  if (depth == points) c.fail("give exactly one of depth (an image) and points (a PLY cloud)");
  e.kind = depth ? ScanEntry::Kind::kDepthImage : ScanEntry::Kind::kPointCloud;
  const std::string file = node[depth ? "depth" : "points"].as<std::string>();
  e.path = (base / file).lexically_normal().string();
  e.name = node["name"] ? node["name"].as<std::string>() : fs::path(file).stem().string();
  c.name = e.name;
  if (e.name.empty() || e.name.find('/') != std::string::npos)
    c.fail("name must be a non-empty file name");
  if (depth) {
    if (node["scanner"]) c.fail("scanner is for point clouds; a depth camera sits at its origin");
    e.intrinsics = read_camera(node["camera"], c, e.depth_scale);
  } else {
    if (node["camera"]) c.fail("camera is for depth images");
    if (node["scanner"]) {
      const std::vector<double> s = numbers(node["scanner"], 3, c, "scanner");
      e.scanner = Eigen::Vector3d(s[0], s[1], s[2]);
    }
  }
  e.T_world_scan = read_pose(node["pose"], c);
  std::error_code ec;  // the throwing overload escapes on a name too long for the file system
  if (!fs::is_regular_file(e.path, ec)) c.fail("no such file: " + e.path);
  return e;
}

}  // namespace

std::vector<ScanEntry> read_scan_manifest(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw input_error(path + ": cannot open the scan manifest");
  std::stringstream buffer;
  buffer << in.rdbuf();
  YAML::Node doc;
  try {
    doc = YAML::Load(buffer.str());
  } catch (const YAML::Exception& e) {
    throw input_error(path + ": not valid YAML or JSON: " + e.msg + " (line " +
                      std::to_string(e.mark.line + 1) + ")");
  }
  if (!doc.IsMap() || !doc["scans"] || !doc["scans"].IsSequence())
    throw input_error(path + ": a scan manifest needs a list 'scans'");
  const fs::path base = fs::path(path).parent_path();
  std::vector<ScanEntry> entries;
  std::set<std::string> names;
  Context c{path, 0, {}};
  for (const YAML::Node& node : doc["scans"]) {
    c.name.clear();
    try {
      entries.push_back(read_entry(node, base, c));
    } catch (const YAML::Exception& e) {
      c.fail("bad value: " + e.msg);
    }
    if (!names.insert(entries.back().name).second) c.fail("another scan has this name");
    ++c.index;
  }
  if (entries.empty()) throw input_error(path + ": the manifest lists no scan");
  return entries;
}

}  // namespace aoscan
