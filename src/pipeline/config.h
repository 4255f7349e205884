/// @file config.h
/// @brief The whole configuration of a run: every module's config struct as one section, loaded,
/// validated and printed through the structs' visit() lists.
///
/// Each struct (next to its module: preprocess_config.h, tsdf_config.h, tracking_config.h,
/// ao_config.h, and PipelineConfig below) lists its fields once in `visit()`; loading
/// (`--config`, `--set`), validation and printing are all driven by that list, so a new field
/// needs one line. Defaults are the values of Sabbadin et al. 2016 Sec. 7 for a Kinect-class
/// camera.
#pragma once

#include <string>
#include <vector>

#include "ao/ao_config.h"
#include "fusion/reconstruction_config.h"

namespace aoscan {

/// The stage thread chain.
struct PipelineConfig {
  int queue_capacity = 2;  ///< frames buffered between two stages

  template <class V>
  void visit(V& v) {
    v.integer("queue_capacity", queue_capacity, "frames buffered between two stages", 1, 1024);
  }
};

/// The whole configuration; keys are `SECTION.FIELD`, e.g. `ao.radius_m`.
struct Config : ReconstructionConfig {
  AoConfig ao;
  PipelineConfig pipeline;

  template <class V>
  void visit_sections(V& v) {
    v.section("preprocess", preprocess);
    v.section("fusion", fusion);
    v.section("tracking", tracking);
    v.section("relocalisation", relocalisation);
    v.section("ao", ao);
    v.section("pipeline", pipeline);
  }
};

/// Applies `KEY=VALUE` to `config`; throws usage_error naming the key on an unknown key or a value
/// that does not parse or is out of range. `origin` names where it came from (a file, `--set`).
void set_config_value(Config& config, const std::string& key, const std::string& value,
                      const std::string& origin);

/// Reads a YAML or JSON file (nested sections or dotted keys) into `config`; throws usage_error
/// naming the file on a missing file, a syntax error, an unknown key or a bad value.
void load_config_file(Config& config, const std::string& path);

/// Checks relations between fields (e.g. min < max); throws usage_error.
void validate_config(const Config& config);

/// Defaults, then `file` (if not empty), then each `KEY=VALUE` of `sets`, then validation.
Config load_config(const std::string& file, const std::vector<std::string>& sets);

/// The configuration as YAML with one comment per key (what `aoscan config` prints).
std::string dump_config(const Config& config);

/// Valid values that make a run or its export much slower or larger than they need to be (an
/// MVAO grid finer than the TSDF, a very fine TSDF): one warning each, naming keys and values.
std::vector<std::string> costly_config_warnings(const Config& config);

}  // namespace aoscan
