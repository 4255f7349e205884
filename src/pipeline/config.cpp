/// @file config.cpp
/// @brief Loading, validating and printing the configuration through the structs' visit() lists.
#include "pipeline/config.h"

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "core/status.h"

namespace aoscan {
namespace {

bool parse_double(const std::string& text, double& out) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (errno != 0 || end != text.c_str() + text.size() || !std::isfinite(v)) return false;
  out = v;
  return true;
}

/// An integer's parse: a value, not a whole number at all, or a whole number beyond `int`.
enum class IntParse { kOk, kNotInteger, kTooLarge };

IntParse parse_int(const std::string& text, int& out) {
  if (text.empty()) return IntParse::kNotInteger;
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size()) return IntParse::kNotInteger;
  if (errno == ERANGE || v < INT_MIN || v > INT_MAX) return IntParse::kTooLarge;
  if (errno != 0) return IntParse::kNotInteger;
  out = static_cast<int>(v);
  return IntParse::kOk;
}

std::string number_text(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

/// `v` in plain digits, as a person writes it (0.00001, not 1e-05).
std::string plain_number(double v) {
  if (std::abs(v) < 1e15 && v == std::floor(v)) return std::to_string(static_cast<long long>(v));
  char text[64];
  std::snprintf(text, sizeof text, "%.10f", v);
  std::string out = text;
  while (out.back() == '0') out.pop_back();
  if (out.back() == '.') out.pop_back();
  return out;
}

/// "must be from LO to HI" (or "at least LO" when HI is beyond any sensible value).
std::string range_text(double lo, double hi) {
  if (hi >= 1e15) return "must be at least " + plain_number(lo);
  return "must be from " + plain_number(lo) + " to " + plain_number(hi);
}

/// Sets the field named `field` of the visited section, if it has one.
class SetVisitor {
 public:
  SetVisitor(std::string key, std::string field, std::string value, std::string origin)
      : key_(std::move(key)), field_(std::move(field)), value_(std::move(value)),
        origin_(std::move(origin)) {}

  void number(const char* name, double& target, const char*, double lo, double hi) {
    if (field_ != name) return;
    found = true;
    double v = 0;
    if (!parse_double(value_, v)) fail("is not a finite number (" + range_text(lo, hi) + ")");
    if (v < lo || v > hi) fail("is out of range: it " + range_text(lo, hi));
    target = v;
  }
  void integer(const char* name, int& target, const char*, int lo, int hi) {
    if (field_ != name) return;
    found = true;
    int v = 0;
    const IntParse parsed = parse_int(value_, v);
    if (parsed == IntParse::kNotInteger)
      fail("is not a whole number (" + range_text(lo, hi) + ")");
    if (parsed == IntParse::kTooLarge || v < lo || v > hi)
      fail("is out of range: it " + range_text(lo, hi));
    target = v;
  }
  template <class E>
  void choice(const char* name, E& target, const char*,
              std::initializer_list<std::pair<const char*, E>> options) {
    if (field_ != name) return;
    found = true;
    std::string names;
    for (const auto& [text, value] : options) {
      if (value_ == text) {
        target = value;
        return;
      }
      names += names.empty() ? text : std::string(", ") + text;
    }
    fail("is not one of: " + names);
  }

  bool found = false;

 private:
  [[noreturn]] void fail(const std::string& why) const {
    throw usage_error(origin_ + ": value '" + value_ + "' of " + key_ + " " + why);
  }
  std::string key_, field_, value_, origin_;
};

/// Writes `key: value  # doc` lines.
class DumpVisitor {
 public:
  explicit DumpVisitor(std::ostringstream& out) : out_(out) {}
  void number(const char* name, double& v, const char* doc, double, double) {
    line(name, number_text(v), doc);
  }
  void integer(const char* name, int& v, const char* doc, int, int) {
    line(name, std::to_string(v), doc);
  }
  template <class E>
  void choice(const char* name, E& v, const char* doc,
              std::initializer_list<std::pair<const char*, E>> options) {
    for (const auto& [text, value] : options)
      if (value == v) line(name, text, doc);
  }

 private:
  void line(const char* name, const std::string& value, const char* doc) {
    out_ << "  " << name << ": " << value << "  # " << doc << "\n";
  }
  std::ostringstream& out_;
};

/// Runs the setter on the section named `wanted`.
struct SectionDispatch {
  const std::string& wanted;
  SetVisitor& setter;
  bool& section_found;
  template <class S>
  void section(const char* name, S& s) {
    if (wanted != name) return;
    section_found = true;
    s.visit(setter);
  }
};

/// Prints every section.
struct SectionDump {
  std::ostringstream& out;
  template <class S>
  void section(const char* name, S& s) {
    out << name << ":\n";
    DumpVisitor dump(out);
    s.visit(dump);
  }
};

/// Keys have two parts (SECTION.FIELD): a deeper tree cannot name one. Flattening stops there, so
/// that a file nested thousands of levels deep is an unknown key, not a stack overflow.
constexpr int kMaxKeyDepth = 8;

[[noreturn]] void too_deep(const std::string& prefix, const std::string& path) {
  throw usage_error(path + ": unknown configuration key '" + prefix.substr(0, 80) +
                    "...' (nested more than " + std::to_string(kMaxKeyDepth) +
                    " levels; aoscan config lists every key)");
}

/// Flattens a YAML tree into dotted keys.
void flatten_yaml(const YAML::Node& node, const std::string& prefix,
                  std::map<std::string, std::string>& out, const std::string& path, int depth = 0) {
  if (node.IsMap()) {
    if (depth >= kMaxKeyDepth) too_deep(prefix, path);
    for (const auto& kv : node) {
      if (!kv.first.IsScalar())
        throw usage_error(path + ": a configuration key must be a word" +
                          (prefix.empty() ? std::string() : " (in " + prefix + ")"));
      const std::string key = kv.first.Scalar();
      flatten_yaml(kv.second, prefix.empty() ? key : prefix + "." + key, out, path, depth + 1);
    }
  } else if (node.IsScalar()) {
    if (!out.emplace(prefix, node.Scalar()).second)
      throw usage_error(path + ": configuration key " + prefix + " is given twice");
  } else if (node.IsNull()) {
    if (!prefix.empty()) throw usage_error(path + ": configuration key " + prefix + " has no value");
  } else {
    throw usage_error(path + ": configuration key " + prefix + " must be a number or a word");
  }
}

void flatten_json(const nlohmann::json& node, const std::string& prefix,
                  std::map<std::string, std::string>& out, const std::string& path, int depth = 0) {
  if (node.is_object()) {
    if (depth >= kMaxKeyDepth) too_deep(prefix, path);
    for (const auto& [key, value] : node.items())
      flatten_json(value, prefix.empty() ? key : prefix + "." + key, out, path, depth + 1);
  } else if (node.is_string() || node.is_number() || node.is_boolean()) {
    if (!out.emplace(prefix, node.is_string() ? node.get<std::string>() : node.dump()).second)
      throw usage_error(path + ": configuration key " + prefix + " is given twice");
  } else {
    throw usage_error(path + ": configuration key " + prefix + " must be a number or a string");
  }
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

void set_config_value(Config& config, const std::string& key, const std::string& value,
                      const std::string& origin) {
  const auto dot = key.find('.');
  const std::string section = dot == std::string::npos ? "" : key.substr(0, dot);
  const std::string field = dot == std::string::npos ? key : key.substr(dot + 1);
  SetVisitor setter(key, field, value, origin);
  bool section_found = false;
  SectionDispatch dispatch{section, setter, section_found};
  config.visit_sections(dispatch);
  if (!section_found || !setter.found)
    throw usage_error(origin + ": unknown configuration key '" + key +
                      "' (aoscan config lists every key)");
}

void load_config_file(Config& config, const std::string& path) {
  std::ifstream in(path);
  if (!in) throw usage_error(path + ": cannot open configuration file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::map<std::string, std::string> values;
  if (ends_with(path, ".json")) {
    nlohmann::json doc;
    // JSON itself lets a later key replace an earlier one silently: find repeats while parsing.
    // Each open object: its dotted prefix and the keys seen in it.
    std::vector<std::pair<std::string, std::set<std::string>>> objects;
    std::string last_key, repeated;
    const auto watch_keys = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
      using Event = nlohmann::json::parse_event_t;
      // Past the deepest key the flattening accepts there is nothing to name: no prefix is
      // built, so that a deeply nested file costs linear time.
      if (event == Event::object_start)
        objects.emplace_back(objects.empty() || objects.size() > kMaxKeyDepth
                                 ? ""
                                 : objects.back().first + last_key + ".",
                             std::set<std::string>{});
      if (event == Event::object_end && !objects.empty()) objects.pop_back();
      if (event == Event::key && !objects.empty()) {
        last_key = parsed.get<std::string>();
        if (repeated.empty() && !objects.back().second.insert(last_key).second)
          repeated = objects.back().first + last_key;
      }
      return true;
    };
    try {
      doc = nlohmann::json::parse(buffer.str(), watch_keys);
    } catch (const nlohmann::json::exception& e) {
      throw usage_error(path + ": not valid JSON: " + e.what());
    }
    if (!repeated.empty())
      throw usage_error(path + ": configuration key " + repeated + " is given twice");
    if (!doc.is_object()) throw usage_error(path + ": configuration must be a JSON object");
    flatten_json(doc, "", values, path);
  } else {
    YAML::Node doc;
    try {
      doc = YAML::Load(buffer.str());
    } catch (const YAML::Exception& e) {
      throw usage_error(path + ": not valid YAML: " + e.what());
    }
    if (!doc.IsMap() && !doc.IsNull())
      throw usage_error(path + ": configuration must be a mapping of keys to values");
    flatten_yaml(doc, "", values, path);
  }
  for (const auto& [key, value] : values) set_config_value(config, key, value, path);
}

void validate_config(const Config& c) {
  if (c.preprocess.min_depth_m >= c.preprocess.max_depth_m)
    throw usage_error("configuration: preprocess.min_depth_m must be below preprocess.max_depth_m");
  if (c.ao.d_min_m >= c.ao.d_max_m)
    throw usage_error("configuration: ao.d_min_m must be below ao.d_max_m");
  const bool point_estimator = c.ao.estimator == AoEstimator::kPaper ||
                               c.ao.estimator == AoEstimator::kObscurance ||
                               c.ao.estimator == AoEstimator::kAlchemy;
  if (!point_estimator && c.ao.view_weight == AoViewWeight::kVardis)
    throw usage_error(
        "configuration: ao.view_weight vardis needs a point estimator (ao.estimator paper, "
        "obscurance or alchemy)");
  if (!point_estimator && c.ao.importance_samples > 0)
    throw usage_error(
        "configuration: ao.importance_samples needs a point estimator (ao.estimator paper, "
        "obscurance or alchemy)");
  if (c.ao.importance_samples >= c.ao.samples)
    throw usage_error("configuration: ao.importance_samples must be below ao.samples (" +
                      std::to_string(c.ao.samples) + "), or 0");
  if (c.fusion.truncation_m < c.fusion.voxel_size_m)
    throw usage_error("configuration: fusion.truncation_m must be at least fusion.voxel_size_m");
}

Config load_config(const std::string& file, const std::vector<std::string>& sets) {
  Config config;
  if (!file.empty()) load_config_file(config, file);
  std::set<std::string> set_keys;
  for (const std::string& kv : sets) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0)
      throw usage_error("--set " + kv + ": expected KEY=VALUE");
    if (!set_keys.insert(kv.substr(0, eq)).second)
      throw usage_error("--set " + kv.substr(0, eq) + " is given twice");
    set_config_value(config, kv.substr(0, eq), kv.substr(eq + 1), "--set");
  }
  validate_config(config);
  return config;
}

std::string dump_config(const Config& config) {
  Config copy = config;
  std::ostringstream out;
  SectionDump dispatch{out};
  copy.visit_sections(dispatch);
  return out.str();
}

std::vector<std::string> costly_config_warnings(const Config& c) {
  std::vector<std::string> warnings;
  const double cell_m = c.ao.grid_extent_m / c.ao.grid_resolution;
  if (cell_m < c.fusion.voxel_size_m)
    warnings.push_back("configuration: the MVAO grid's cells (ao.grid_extent_m / "
                       "ao.grid_resolution = " + plain_number(cell_m) +
                       " m) are finer than the TSDF's voxels (fusion.voxel_size_m = " +
                       plain_number(c.fusion.voxel_size_m) +
                       " m): more memory and a longer export for no finer AO");
  // Below about 4 mm a room's TSDF holds tens of millions of voxels: integration, raycast and
  // the mesh export slow down by the cube of the refinement.
  constexpr double kFineVoxelM = 0.004;
  if (c.fusion.voxel_size_m < kFineVoxelM)
    warnings.push_back("configuration: fusion.voxel_size_m = " +
                       plain_number(c.fusion.voxel_size_m) + " m is below " +
                       plain_number(kFineVoxelM) +
                       " m: fusion and the mesh export take much longer and more memory");
  return warnings;
}

}  // namespace aoscan
