/// @file meshlab_project.cpp
/// @brief Reading MeshLab projects with tinyxml2.
#include "io/meshlab_project.h"

#include <cmath>
#include <filesystem>
#include <system_error>
#include <set>
#include <sstream>

#include <tinyxml2.h>

#include "core/status.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

Pose layer_pose(const tinyxml2::XMLElement* layer, const std::string& where) {
  const tinyxml2::XMLElement* matrix = layer->FirstChildElement("MLMatrix44");
  if (matrix == nullptr || matrix->GetText() == nullptr) return Pose::identity();
  std::istringstream text(matrix->GetText());
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) {
    double v = 0.0;
    if (!(text >> v) || !std::isfinite(v))
      throw input_error(where + ": MLMatrix44 must hold 16 finite numbers");
    m(i / 4, i % 4) = v;
  }
  std::string rest;
  if (text >> rest) throw input_error(where + ": MLMatrix44 holds more than 16 numbers");
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6 ||
      (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-4 || R.determinant() < 0.0)
    throw input_error(where + ": MLMatrix44 is not a rigid transform");
  return Pose::from_matrix(m).normalized();
}

}  // namespace

std::vector<ScanEntry> read_meshlab_project(const std::string& path) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) {
    std::error_code ec;  // the throwing overloads escape on a name too long for the file system
    if (!fs::exists(path, ec)) throw input_error(path + ": cannot open MeshLab project");
    throw input_error(path + ": not a MeshLab project (XML error: " +
                      std::string(doc.ErrorStr() ? doc.ErrorStr() : "unknown") + ")");
  }
  const tinyxml2::XMLElement* project = doc.FirstChildElement("MeshLabProject");
  const tinyxml2::XMLElement* group = project ? project->FirstChildElement("MeshGroup") : nullptr;
  if (group == nullptr) throw input_error(path + ": not a MeshLab project (no MeshGroup)");
  const fs::path base = fs::path(path).parent_path();
  std::vector<ScanEntry> entries;
  std::set<std::string> names;
  int index = 0;
  for (const tinyxml2::XMLElement* layer = group->FirstChildElement("MLMesh"); layer != nullptr;
       layer = layer->NextSiblingElement("MLMesh")) {
    ++index;
    const std::string where = path + ": layer " + std::to_string(index);
    const char* file = layer->Attribute("filename");
    if (file == nullptr || *file == '\0') throw input_error(where + ": no filename");
    ScanEntry e;
    e.kind = ScanEntry::Kind::kPointCloud;
    e.path = (base / file).lexically_normal().string();
    const char* label = layer->Attribute("label");
    e.name = label && *label ? label : fs::path(file).stem().string();
    if (e.name.find('/') != std::string::npos) e.name = fs::path(e.name).filename().string();
    if (e.name.empty())  // a label such as "/scan/" has no file name to keep
      throw input_error(where + ": label '" + std::string(label ? label : "") + "' is not a name");
    if (fs::path(e.path).extension() != ".ply")
      throw input_error(where + " (" + e.name + "): " + e.path + " is not a PLY file");
    std::error_code ec;
    if (!fs::is_regular_file(e.path, ec))
      throw input_error(where + " (" + e.name + "): no such file: " + e.path);
    e.T_world_scan = layer_pose(layer, where + " (" + e.name + ")");
    if (!names.insert(e.name).second)
      throw input_error(where + ": another layer is named " + e.name);
    entries.push_back(std::move(e));
  }
  if (entries.empty()) throw input_error(path + ": the MeshLab project has no layer");
  return entries;
}

}  // namespace aoscan
