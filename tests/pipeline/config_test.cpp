// Tests for src/pipeline/config.cpp: defaults, --set, files, validation.
#include "pipeline/config.h"

#include <cstdio>
#include <fstream>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "core/status.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

/// Writes `text` to the file `name` of `dir`; returns its path.
std::string write_temp(const testing::ScratchDir& dir, const std::string& name,
                       const std::string& text) {
  const std::string path = dir.file(name);
  testing::write_text(path, text);
  return path;
}

ExitCode code_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  return ExitCode::kOk;
}

TEST(Config, DefaultsArePaperValues) {
  const Config c = load_config("", {});
  EXPECT_DOUBLE_EQ(c.ao.radius_m, 0.1);
  EXPECT_DOUBLE_EQ(c.ao.t_max_m, 0.2);
  EXPECT_DOUBLE_EQ(c.ao.d_min_m, 0.4);
  EXPECT_DOUBLE_EQ(c.ao.d_max_m, 3.0);
  EXPECT_DOUBLE_EQ(c.preprocess.outlier_threshold_m, 0.02);
  EXPECT_EQ(c.ao.grid_resolution, 512);
  EXPECT_DOUBLE_EQ(c.ao.grid_extent_m, 4.0);
  // 16, not the paper's 32: equal MVAO accuracy at stride 2 for half the cost (config.h).
  EXPECT_EQ(c.ao.samples, 16);
  EXPECT_EQ(c.ao.integration, AoIntegration::kMvao);
  EXPECT_EQ(c.ao.input, AoInput::kRaycast);
}

TEST(Config, SetOverridesNumbersAndChoices) {
  const Config c = load_config(
      "", {"ao.radius_m=0.25", "ao.integration=last", "ao.input=raw", "pipeline.queue_capacity=8"});
  EXPECT_DOUBLE_EQ(c.ao.radius_m, 0.25);
  EXPECT_EQ(c.ao.integration, AoIntegration::kLast);
  EXPECT_EQ(c.ao.input, AoInput::kRaw);
  EXPECT_EQ(c.pipeline.queue_capacity, 8);
}

TEST(Config, BadKeysAndValuesAreUsageErrors) {
  for (const std::string set : {"ao.nope=1", "nope.radius_m=1", "radius_m=1", "ao.radius_m=abc",
                                "ao.radius_m=nan", "ao.radius_m=-1", "ao.radius_m=",
                                "ao.samples=2.5", "ao.integration=median", "noequals", "=3"}) {
    EXPECT_EQ(code_of([&] { load_config("", {set}); }), ExitCode::kUsage) << set;
  }
  try {
    load_config("", {"ao.nope=1"});
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ao.nope"), std::string::npos);
  }
}

TEST(Config, CrossFieldValidation) {
  EXPECT_EQ(code_of([] { load_config("", {"ao.d_min_m=3", "ao.d_max_m=2"}); }), ExitCode::kUsage);
  EXPECT_EQ(code_of([] { load_config("", {"preprocess.min_depth_m=5"}); }), ExitCode::kUsage);
  // Vardis et al.'s weight and importance sampling need a point estimator; importance sampling
  // fewer initial samples than ao.samples.
  EXPECT_EQ(code_of([] { load_config("", {"ao.view_weight=vardis", "ao.estimator=horizon"}); }),
            ExitCode::kUsage);
  EXPECT_EQ(code_of([] { load_config("", {"ao.importance_samples=4", "ao.estimator=statvo"}); }),
            ExitCode::kUsage);
  EXPECT_EQ(code_of([] { load_config("", {"ao.importance_samples=16"}); }), ExitCode::kUsage);
  EXPECT_EQ(code_of([] {
              load_config("", {"ao.view_weight=vardis", "ao.importance_samples=4",
                               "ao.estimator=obscurance"});
            }),
            ExitCode::kOk);
}

TEST(Config, YamlFileNestedAndDotted) {
  aoscan::testing::ScratchDir scratch;
  const auto path = write_temp(scratch, "cfg.yaml",
                               "ao:\n  radius_m: 0.3\n  integration: mean\n"
                               "preprocess.outlier_threshold_m: 0.05\n");
  const Config c = load_config(path, {"ao.radius_m=0.4"});  // --set wins over the file
  EXPECT_DOUBLE_EQ(c.ao.radius_m, 0.4);
  EXPECT_EQ(c.ao.integration, AoIntegration::kMean);
  EXPECT_DOUBLE_EQ(c.preprocess.outlier_threshold_m, 0.05);
}

TEST(Config, JsonFile) {
  aoscan::testing::ScratchDir scratch;
  const auto path = write_temp(scratch, "cfg.json", R"({"ao": {"samples": 16, "input": "raw"}})");
  const Config c = load_config(path, {});
  EXPECT_EQ(c.ao.samples, 16);
  EXPECT_EQ(c.ao.input, AoInput::kRaw);
}

TEST(Config, BrokenFilesAreUsageErrorsNamingTheFile) {
  aoscan::testing::ScratchDir scratch;
  const auto bad_yaml = write_temp(scratch, "bad.yaml", "ao: [1, 2\n");
  const auto bad_json = write_temp(scratch, "bad.json", "{\"ao\": ");
  const auto bad_key = write_temp(scratch, "badkey.yaml", "ao:\n  colour: red\n");
  for (const auto& path : {bad_yaml, bad_json, bad_key, std::string("/nonexistent/cfg.yaml")}) {
    try {
      load_config(path, {});
      ADD_FAILURE() << path;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kUsage);
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

// Found by fuzz/config_json_fuzz: a JSON file nested 100000 levels deep overflowed the stack
// while its keys were flattened. Keys have two parts, so deep nesting is an unknown key.
TEST(Config, DeeplyNestedFilesAreUsageErrorsNamingTheFile) {
  aoscan::testing::ScratchDir scratch;
  constexpr int kLevels = 100000;
  std::string json, yaml;
  for (int i = 0; i < kLevels; ++i) json += "{\"a\":";
  json += "1" + std::string(kLevels, '}');
  for (int i = 0; i < 20; ++i) yaml += std::string(2 * i, ' ') + "a:\n";  // block style
  yaml += std::string(40, ' ') + "b: 1\n";
  const auto deep_json = write_temp(scratch, "deep.json", json);
  const auto deep_yaml = write_temp(scratch, "deep.yaml", yaml);
  const auto nine = write_temp(scratch, "nine.json", R"({"a":{"a":{"a":{"a":{"a":{"a":{"a":{"a":{"a":1}}}}}}}}})");
  for (const auto& path : {deep_json, deep_yaml, nine}) {
    try {
      load_config(path, {});
      ADD_FAILURE() << path;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kUsage);
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path + ": unknown configuration key 'a.a.a.a.a.a.a.a...' (nested more "
                              "than 8 levels", 0),
                0u)
          << message;
    }
  }
  // Three levels still reach the key check as before.
  const auto three = write_temp(scratch, "three.json", R"({"ao": {"radius_m": {"x": 1}}})");
  try {
    load_config(three, {});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              three + ": unknown configuration key 'ao.radius_m.x' (aoscan config lists every key)");
  }
}

// Found by fuzz/config_fuzz: a YAML key that is a list or a map ("{[a]: 1}") escaped as
// yaml-cpp's conversion exception instead of a usage error naming the file.
TEST(Config, YamlKeyThatIsNotAWordIsAUsageErrorNamingTheFile) {
  aoscan::testing::ScratchDir scratch;
  const auto list_key = write_temp(scratch, "listkey.yaml", "{[a]: 1}\n");
  const auto map_key = write_temp(scratch, "mapkey.yaml", "ao:\n  ? {radius_m: 1}\n  : 2\n");
  try {
    load_config(list_key, {});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_EQ(std::string(e.what()), list_key + ": a configuration key must be a word");
  }
  try {
    load_config(map_key, {});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_EQ(std::string(e.what()), map_key + ": a configuration key must be a word (in ao)");
  }
}

TEST(Config, KeysGivenTwiceAreUsageErrors) {
  aoscan::testing::ScratchDir scratch;
  const auto yaml = write_temp(scratch, "twice.yaml", "ao:\n  radius_m: 0.3\n  radius_m: 0.4\n");
  const auto mixed = write_temp(scratch, "mixed.yaml", "ao:\n  radius_m: 0.3\nao.radius_m: 0.4\n");
  const auto json = write_temp(scratch, "twice.json", R"({"ao": {"samples": 8, "samples": 16}})");
  for (const auto& path : {yaml, mixed, json}) {
    try {
      load_config(path, {});
      ADD_FAILURE() << path;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kUsage);
      EXPECT_NE(std::string(e.what()).find(path + ": configuration key ao."), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(" is given twice"), std::string::npos) << e.what();
    }
  }
  // The same key in two objects is no repeat.
  const auto apart = write_temp(scratch, "apart.json", R"({"ao": {"samples": 8}, "tracking": {}})");
  EXPECT_EQ(load_config(apart, {}).ao.samples, 8);
  EXPECT_EQ(code_of([] { load_config("", {"ao.samples=8", "ao.samples=9"}); }), ExitCode::kUsage);
}

TEST(Config, RangesAreNamedInPlainNumbers) {
  try {
    load_config("", {"ao.bias=-1"});
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("ao.bias is out of range: it must be"), std::string::npos) << what;
    EXPECT_EQ(what.find("e-"), std::string::npos) << what;  // no exponent
    EXPECT_EQ(what.find("e+"), std::string::npos) << what;
  }
}

TEST(Config, CostlyValuesAreWarned) {
  EXPECT_TRUE(costly_config_warnings(Config{}).empty());
  Config fine;
  fine.fusion.voxel_size_m = 0.002;
  fine.fusion.truncation_m = 0.01;
  ASSERT_EQ(costly_config_warnings(fine).size(), 1u);
  EXPECT_NE(costly_config_warnings(fine)[0].find("fusion.voxel_size_m = 0.002 m"), std::string::npos);
  Config grid;
  grid.ao.grid_resolution = 1024;  // 3.9 mm cells under 7.8 mm voxels
  ASSERT_EQ(costly_config_warnings(grid).size(), 1u);
  EXPECT_NE(costly_config_warnings(grid)[0].find("0.00390625 m"), std::string::npos);
}

TEST(Config, DumpRoundTrips) {
  aoscan::testing::ScratchDir scratch;
  Config changed = load_config("", {"ao.radius_m=0.15", "ao.integration=last"});
  const auto path = write_temp(scratch, "dump.yaml", dump_config(changed));
  const Config back = load_config(path, {});
  EXPECT_EQ(dump_config(back), dump_config(changed));
  EXPECT_DOUBLE_EQ(back.ao.radius_m, 0.15);
  EXPECT_EQ(back.ao.integration, AoIntegration::kLast);
}

}  // namespace
}  // namespace aoscan
